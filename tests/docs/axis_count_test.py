"""One shape for any number of axes: the places in firmware/ and host/ that
branch on how many axes there are (a count compared with 1 or 2) are the
few docs/architecture.md names and justifies, file by file ("Where the
count of axes matters"). A new one fails here until it is justified there,
or written for any count instead."""

import os
import re

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ROOTS = ("firmware", "host")
SUFFIXES = (".cpp", ".hpp", ".py", ".js", ".html")

# A count of axes (or of what a run has one of per axis) against 1 or 2.
COUNTED = r"(?:\w*(?:axes|moves|targets|group)\w*|names)"
BRANCH = re.compile(
    rf"\b{COUNTED}(?:\(\))?\.size\(\)\s*(?:==|!=|<=|>=|<|>)\s*[12]\b"  # C++
    rf"|\blen\(\s*(?:self\.)?{COUNTED}\s*\)\s*(?:==|!=|<=|>=|<|>)\s*[12]\b"  # Python
    rf"|\b{COUNTED}\.length\s*(?:===|!==|==|!=|<=|>=|<|>)\s*[12]\b")  # JavaScript


def branches():
    """{path: count} of the lines that branch on the count of axes."""
    found = {}
    for root in ROOTS:
        for folder, _, files in os.walk(os.path.join(SOURCE, root)):
            for name in files:
                if not name.endswith(SUFFIXES):
                    continue
                path = os.path.join(folder, name)
                with open(path, encoding="utf-8", errors="replace") as f:
                    n = sum(1 for line in f if BRANCH.search(line))
                if n:
                    found[os.path.relpath(path, SOURCE)] = n
    return found


def documented():
    """{path: count} from the architecture page's table."""
    page = open(os.path.join(SOURCE, "docs", "architecture.md"), encoding="utf-8").read()
    section = page.split("\n## Where the count of axes matters\n", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| `([^`]+)` \| (\d+) \|", section, re.MULTILINE)
    return {path: int(n) for path, n in rows}


def test_the_places_that_branch_on_the_count_of_axes_are_the_documented_few():
    found, named = branches(), documented()
    assert named, "the architecture page names none"
    assert found == named, (
        "lines that branch on how many axes there are, by file (found vs documented in "
        f"docs/architecture.md): {found} vs {named}")
    total = sum(found.values())
    print(f"{total} lines in {len(found)} files branch on the count of axes")
    assert total <= 15, total


def test_the_pattern_finds_what_it_should():
    for line in ("if (axes_.size() > 1)", "board.axes.size() == 1 ? a : b",
                 "if len(axes) == 1:", "names.length === 1", "if len(names) == 1:"):
        assert BRANCH.search(line), line
    for line in ("axes.size() == 3", "if (axes_.empty())", "for (i < axes.size())",
                 "if len(parts) != 2:", "kStopCauseNames.size() == 1"):
        assert not BRANCH.search(line), line
