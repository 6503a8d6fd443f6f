"""The site's build hooks (mkdocs `hooks:`): the changelog page is CHANGELOG.md itself, and each
page's `{{ name }}` becomes the value of that entry of docs/numbers.yaml, so that a figure
quoted on several pages is written once; a name not there stops the build."""

import re
from pathlib import Path

import yaml
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

NUMBERS = Path(__file__).with_name("numbers.yaml")
CHANGELOG = Path(__file__).parents[1] / "CHANGELOG.md"
PLACEHOLDER = re.compile(r"\{\{\s*([a-z0-9_]+)\s*\}\}")


def numbers() -> dict[str, dict]:
    return yaml.safe_load(NUMBERS.read_text())


def fill(markdown: str, entries: dict[str, dict], where: str) -> str:
    """The page with each placeholder replaced by its entry's value."""
    def value(match: re.Match) -> str:
        if match[1] not in entries:
            raise PluginError(f"{where}: {{{{ {match[1]} }}}} is not in {NUMBERS.name}; "
                              f"add it there (value, what, source) or fix the name")
        return str(entries[match[1]]["value"])
    return PLACEHOLDER.sub(value, markdown)


def on_page_markdown(markdown: str, page, **kwargs) -> str:
    return fill(markdown, numbers(), page.file.src_path)


def on_files(files, config):
    files.append(File.generated(config, "changelog.md", abs_src_path=str(CHANGELOG)))
    return files
