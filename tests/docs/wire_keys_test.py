"""Each key of the protocol's messages is one string literal in the C++
that speaks the wire (the codec, the daemon, the requests, the host's run
and view, the live page's board watch): the field lists, the request
arguments and firmware/include/piezo/firmware/wire_keys.hpp declare them,
and everything else takes them by name, so a misspelled key does not
compile. Not counted: comments, an enum's name table (its values are
names, not keys), a command's name given to `call` and a topic given to
`subscribe` (their own tables). The CLI's own JSON outputs are a format of
their own (docs/commands.md) and are not scanned."""

import collections
import os
import re

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WIRE = ("firmware/protocol", "firmware/daemon", "firmware/src", "firmware/include",
        "host/src/run", "host/src/view", "host/src/cli/board_watch.cpp")
KEYS_HEADER = "firmware/include/piezo/firmware/wire_keys.hpp"
NAME_ENTRY = re.compile(r'\{\s*[A-Za-z_:]+::\w+,\s*"\w+"\s*\}')
NOT_KEYS = re.compile(r'(call|send|subscribe)\(\{?"[^)]*\)')
LITERAL = re.compile(r'"([A-Za-z_]\w*)"')


def read(path):
    return open(os.path.join(SOURCE, path), encoding="utf-8").read()


def wire_sources():
    for entry in WIRE:
        full = os.path.join(SOURCE, entry)
        if os.path.isfile(full):
            yield entry
            continue
        for folder, _, files in os.walk(full):
            for name in files:
                if name.endswith((".cpp", ".hpp")):
                    path = os.path.relpath(os.path.join(folder, name), SOURCE)
                    if path != KEYS_HEADER:
                        yield path


def declared_keys():
    keys = set(re.findall(r'field\("(\w+)"', read("firmware/protocol/src/messages.cpp")))
    keys |= set(re.findall(r'Argument \w+\{\s*"(\w+)"',
                           read("firmware/include/piezo/firmware/request_arguments.hpp")))
    return keys | shared_keys()


def code_of(line):
    """The line without its comment, name-table entries, commands and topics."""
    if line.lstrip().startswith(("//", "#include", "*", "///")):
        return ""
    line = re.split(r'(?<![:"])//', line, maxsplit=1)[0]
    return NOT_KEYS.sub("", NAME_ENTRY.sub("", line))


def literal_sites(keys):
    sites = collections.defaultdict(list)
    for path in wire_sources():
        for number, line in enumerate(read(path).splitlines(), 1):
            for key in LITERAL.findall(code_of(line)):
                if key in keys:
                    sites[key].append(f"{path}:{number}")
    return sites


def test_the_declarations_hold_the_keys_the_messages_use():
    keys = declared_keys()
    for key in ("board_ns", "lease_s", "drive", "on_target_at_s", "calibration", "V0"):
        assert key in keys, key


def shared_keys():
    return set(re.findall(r'std::string_view \w+ = "(\w+)";', read(KEYS_HEADER)))


def test_each_wire_key_is_one_literal():
    # A shared key's one literal is its declaration in the header.
    shared = shared_keys()
    repeated = {k: v for k, v in literal_sites(declared_keys()).items()
                if len(v) > (0 if k in shared else 1)}
    assert repeated == {}, (
        "wire keys written more than once (declare a shared one in "
        f"{KEYS_HEADER} and take it by name): {repeated}")


def test_the_counting_sees_a_repeat():
    # The scan itself: a second literal of a declared key is found.
    keys = declared_keys()
    assert LITERAL.findall(code_of('  j["lease_s"] = 1.0;  // "drive"')) == ["lease_s"]
    assert LITERAL.findall(code_of('  client.call("clock");')) == []
    assert "lease_s" in keys


def test_the_defaults_and_the_rate_rule_are_written_once():
    counts = collections.Counter()
    patterns = {"the sensor radius default": r"= 0\.062\b",
                "the lease default": r"kDefaultLease_s = ",
                "the drive's fastest frequency rule": r"rate_hz / 20"}
    for tree in ("firmware", "host", "hal", "model"):
        for folder, _, files in os.walk(os.path.join(SOURCE, tree)):
            for name in files:
                if name.endswith((".cpp", ".hpp", ".py")):
                    text = open(os.path.join(folder, name), encoding="utf-8").read()
                    for what, pattern in patterns.items():
                        counts[what] += len(re.findall(pattern, text))
    assert counts == {what: 1 for what in patterns}, counts


# -- the Python client (host/python/piezo_rig) ---------------------------------
PYTHON = "host/python/piezo_rig"
PYTHON_TABLE = f"{PYTHON}/_wire.py"
# The modules that speak the wire (model.py and log.py do not: the log's
# HDF5 schema has names of its own).
PYTHON_WIRE = ("board.py", "follower.py", "trigger.py", "errors.py", "frames.py", "tango_link.py",
               "tango_server.py")
# Literals that are a wire word by their spelling only.
NOT_WIRE = {("board.py", "timeout"): "the Board's own parameter, named in its refusal",
            ("frames.py", "names"): "numpy's dtype spec"}


def python_words():
    """Every word the generated table holds (keys, commands, names, topics)."""
    return set(re.findall(r'^    \w+ = "(\w+)"$', read(PYTHON_TABLE), re.M))


def test_the_python_table_is_what_its_generator_writes_now():
    import subprocess
    import sys
    done = subprocess.run([sys.executable, os.path.join(SOURCE, "scripts", "wire_table.py"),
                           "--check"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    words = python_words()
    for word in ("position_rad", "idle", "on_target", "stale_board", "moved", "move_to"):
        assert word in words, word


def test_no_wire_word_is_a_literal_in_the_python_client():
    import io
    import tokenize
    words = python_words()
    found = []
    for name in PYTHON_WIRE:
        path = f"{PYTHON}/{name}"
        tokens = list(tokenize.generate_tokens(io.StringIO(read(path)).readline))
        for i, t in enumerate(tokens):
            m = re.fullmatch(r'b?"(\w+)"', t.string) if t.type == tokenize.STRING else None
            if not m or m.group(1) not in words or (name, m.group(1)) in NOT_WIRE:
                continue
            if i >= 2 and tokens[i - 1].string == "=" and tokens[i - 2].string == "unit":
                continue  # a Tango attribute's unit
            found.append(f"{path}:{t.start[0]} {t.string}")
    assert found == [], ("wire words written as literals (take them from "
                         f"{PYTHON_TABLE}): {found}")
