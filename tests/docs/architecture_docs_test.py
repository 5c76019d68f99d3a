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

