"""Every package of the workspace has a README that names each of its executables (issue 30), and the top-level
README and docs/ link only to files that exist."""
from __future__ import annotations

import re

import pytest

from conftest import REPO, console_scripts

PACKAGES = sorted(p.parent.name for p in REPO.glob("src/*/setup.py"))


@pytest.mark.parametrize("package", PACKAGES)
def test_each_package_readme_names_its_executables(package):
    readme = REPO / "src" / package / "README.md"
    assert readme.is_file(), f"{package} has no README.md"
    text = readme.read_text()
    setup = (REPO / "src" / package / "setup.py").read_text()
    mine = [name for name, target in console_scripts().items() if f'"{name} = {target}"' in setup]
    missing = [name for name in mine if f"`{name}" not in text]
    assert not missing, f"{readme}: executables not named: {missing}"


def _links(path):
    """Relative link targets (no anchors, no URLs) of a Markdown file."""
    for target in re.findall(r"\]\(([^)\s]+)\)", path.read_text()):
        if not re.match(r"[a-z]+:", target) and not target.startswith("#"):
            yield target.split("#")[0]


@pytest.mark.parametrize("doc", ["README.md", *sorted(str(p.relative_to(REPO)) for p in REPO.glob("docs/*.md"))])
def test_the_readme_and_docs_link_to_files_that_exist(doc):
    path = REPO / doc
    broken = [t for t in _links(path) if not (path.parent / t).exists()]
    assert not broken, f"{doc}: links to missing files {broken}"
