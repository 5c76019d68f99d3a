"""What the documentation shows a Python user runs as shown: every Python
block of docs/python.md (in order, one session, as a reader pastes them)
and every example in the package's docstrings (doctest), against a real
piezod and a real `piezo run` log; and mypy passes over the package and
the documentation's examples, so a documented call cannot drift from the
code."""

import doctest
import importlib
import os
import re
import subprocess
import sys

import h5py
import numpy as np
import pytest

import piezo_rig

# The documents and docstrings name the default address; the test's board
# listens on a free port.
DOCUMENTED_ADDRESS = "tcp://127.0.0.1:5555"
# ...and a board of several axes (configs/three-axes.toml) this one.
DOCUMENTED_AXES_ADDRESS = "tcp://127.0.0.1:5565"
MODULES = ["piezo_rig", "piezo_rig.model", "piezo_rig.board", "piezo_rig.log",
           "piezo_rig.errors", "piezo_rig.frames"]


def python_blocks(path):
    with open(path) as f:
        return re.findall(r"```python\n(.*?)```", f.read(), re.S)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory, piezo, source):
    """A reader's directory: `runs/first` (a `piezo run` log, as the
    notebooks' section says to make it) and `bench.mat` (another tool's
    MATLAB v7.3 file with /data/t, /data/u, /data/phi)."""
    here = tmp_path_factory.mktemp("reader")
    piezo("run", "--config", os.path.join(source, "configs", "sim.toml"), "--set",
          "run.clock=virtual", "--duration", "1", "--out", str(here / "runs" / "first"), "--json")
    t = np.arange(0, 0.2, 1e-4)
    with h5py.File(here / "bench.mat", "w", userblock_size=512) as f:
        for name, values in (("t", t), ("u", 40 * (t * 10 % 1)), ("phi", 1e-3 * t)):
            f.create_dataset(f"data/{name}", data=values.reshape(1, -1))
    old = os.getcwd()
    os.chdir(here)
    yield here
    os.chdir(old)


@pytest.fixture(scope="module")
def axes_address(tmp_path_factory, source):
    import peers
    process, address = peers.start_piezod(
        os.environ["PIEZOD_BINARY"], os.path.join(source, "configs", "three-axes.toml"),
        str(tmp_path_factory.mktemp("axes") / "piezod.err"))
    yield address
    process.terminate()
    process.wait(10)


def test_every_python_block_of_the_guide_runs(workdir, board_address, axes_address, source):
    blocks = python_blocks(os.path.join(source, "docs", "python.md"))
    assert len(blocks) >= 3
    session: dict = {}
    for i, block in enumerate(blocks):
        code = block.replace(DOCUMENTED_ADDRESS, board_address).replace(
            DOCUMENTED_AXES_ADDRESS, axes_address)
        try:
            exec(compile(code, f"docs/python.md, Python block {i + 1}", "exec"), session)
        except Exception as e:
            pytest.fail(f"docs/python.md, Python block {i + 1} raised {e!r}:\n{block}")


@pytest.mark.parametrize("name", MODULES)
def test_every_docstring_example_runs(workdir, board_address, name):
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    # The exceptions' words are compared too: a docstring promises them.
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = finder.find(module, name)
    for test in tests:
        for example in test.examples:
            example.source = example.source.replace(DOCUMENTED_ADDRESS, board_address)
        runner.run(test, out=sys.stdout.write)
    assert runner.failures == 0, f"{runner.failures} docstring examples of {name} failed"


def test_a_documented_module_has_examples():
    examples = sum(len(t.examples) for name in MODULES
                   for t in doctest.DocTestFinder().find(importlib.import_module(name), name))
    assert examples >= 15


def mypy(*paths, cwd):
    package = os.path.dirname(os.path.dirname(piezo_rig.__file__))
    config = os.path.join(os.environ["PIEZO_SOURCE_DIR"], "host", "python", "pyproject.toml")
    return subprocess.run([sys.executable, "-m", "mypy", "--config-file", config,
                           "--cache-dir", os.path.join(str(cwd), ".mypy_cache"), *paths],
                          capture_output=True, text=True, cwd=cwd,
                          env={**os.environ, "MYPYPATH": package})


def test_mypy_passes_over_the_package_and_the_guide(tmp_path, source):
    package = os.path.dirname(piezo_rig.__file__)
    # The guide's blocks as one script, in order, as a reader runs them.
    script = tmp_path / "python_guide.py"
    script.write_text("\n".join(python_blocks(os.path.join(source, "docs", "python.md"))))
    result = mypy(package, str(script), cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert os.path.exists(os.path.join(package, "_model.pyi")), "the compiled module has stubs"


def test_the_package_passes_mypy_strict(tmp_path):
    """Every annotation complete: what a user's --strict project sees of it."""
    result = mypy("--strict", "-p", "piezo_rig", cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_catches_a_wrong_argument_before_it_runs(tmp_path):
    script = tmp_path / "wrong.py"
    script.write_text("from piezo_rig import model\nmodel.simulate(model.Parameters(), '1')\n"
                      "model.Parameters(V0=60).sigma0 = 'x'\n"
                      "model.Parameters(V0='60')\nmodel.Parameters(direction=1)\n"
                      "model.sensitivity()['paramters']\n")
    result = mypy(str(script), cwd=tmp_path)
    assert result.returncode == 1
    assert 'Argument 2 to "simulate" has incompatible type "str"; expected "float"' in result.stdout
    assert 'Incompatible types in assignment (expression has type "str", variable has type ' \
           '"float")' in result.stdout
    # Each keyword of Parameters has its own type (not "float | str" for all).
    assert 'Argument "V0" to "Parameters" has incompatible type "str"; expected "float"' \
        in result.stdout
    assert 'Argument "direction" to "Parameters" has incompatible type "int"; expected "str"' \
        in result.stdout
    # A study's result is a typed dict: a misspelt key is caught.
    assert 'TypedDict "SensitivityStudy" has no key "paramters"' in result.stdout


def _table_after(page: str, heading: str) -> list[str]:
    rows, found = [], False
    for line in page.splitlines():
        if not found:
            found = line == heading
        elif line.startswith("| `"):
            rows.append(line)
        elif rows:
            break
    assert found, heading
    return rows


def test_every_error_code_protocol_md_lists_has_its_exception(source):
    """The board's refusals (docs/protocol.md, "Errors") each raise their own
    exception class, and the package knows no code the document lacks."""
    from piezo_rig.errors import ERRORS
    page = open(os.path.join(source, "docs", "protocol.md"), encoding="utf-8").read()
    documented = {re.match(r"\| `([a-z_]+)`", row).group(1)
                  for row in _table_after(page, "### Errors")}
    assert "not_controller" in documented
    assert set(ERRORS) == documented


def test_the_package_has_no_import_circle():
    """Each module's imports of its siblings, at the top or inside a
    function, form no circle: `log` reads files and may use `model`; `model`
    never needs `log`."""
    import ast
    package = os.path.dirname(piezo_rig.__file__)
    imports: dict[str, set[str]] = {}
    for name in os.listdir(package):
        if not name.endswith(".py"):
            continue
        tree = ast.parse(open(os.path.join(package, name), encoding="utf-8").read())
        found = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                found |= {node.module} if node.module else {a.name for a in node.names}
        imports[name[:-3]] = {m.split(".")[0] for m in found}

    def reaches(start: str, goal: str, seen: set[str]) -> bool:
        return any(m == goal or (m not in seen and reaches(m, goal, seen | {m}))
                   for m in imports.get(start, ()))

    circles = [m for m in imports if reaches(m, m, {m})]
    assert circles == [], f"modules on an import circle: {circles} ({imports})"
