"""docs/architecture.md's recipes name the files a change touches: each
path they give (a backticked one with a folder in it) must exist in the
tree, so a recipe cannot go on naming a file that was moved or removed."""

import glob
import os
import re

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def recipe_paths():
    page = open(os.path.join(SOURCE, "docs", "architecture.md"), encoding="utf-8").read()
    recipes = page.split("\n## Recipes\n", 1)[1].split("\n## ", 1)[0]
    for token in re.findall(r"`([^`\s]+)`", recipes):
        # A path: a folder and a file or a folder; not an option, a call or a key.
        if "/" in token and not token.startswith(("-", "[")) and "(" not in token:
            yield token


def test_the_recipes_name_files_that_exist():
    paths = list(recipe_paths())
    assert "firmware/include/piezo/firmware/move_request.hpp" in paths, paths
    missing = [p for p in paths if not glob.glob(os.path.join(SOURCE, p))]
    assert missing == [], f"docs/architecture.md's recipes name paths that do not exist: {missing}"



# The folders whose headers other folders include by folder and name
# ("io/run_log.hpp"): their roots are the only include roots they add.
FOLDER_ROOTS = {"host/src": ("cli", "io", "jobs", "run", "studies", "view"),
                "firmware": ("config", "daemon")}


def test_an_include_from_another_folder_carries_its_folder():
    owner = {}
    for root, folders in FOLDER_ROOTS.items():
        for folder in folders:
            for header in glob.glob(os.path.join(SOURCE, root, folder, "*.hpp")):
                owner[os.path.basename(header)] = os.path.dirname(header)
    bare = []
    for tree in ("firmware", "host", "hal", "model", "tests"):
        for path in glob.glob(os.path.join(SOURCE, tree, "**", "*.[ch]pp"), recursive=True):
            here = os.path.dirname(path)
            for name in re.findall(r'^#include "([^"/]+)"', open(path, encoding="utf-8").read(), re.M):
                # A name of the file's own folder (or a test helper's) is found there first.
                if name in owner and not os.path.exists(os.path.join(here, name)):
                    bare.append(f"{os.path.relpath(path, SOURCE)}: {name}")
    assert bare == [], f"includes that name another folder's header without its folder: {bare}"
