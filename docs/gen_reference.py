"""Writes the reference pages into the site at build time (mkdocs-gen-files): generated from the
code by ballmill.reference, never kept in git."""

import mkdocs_gen_files

from ballmill.reference import PAGES

for name, page in PAGES.items():
    with mkdocs_gen_files.open(f"reference/{name}.md", "w") as f:
        f.write(page())
