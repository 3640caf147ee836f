"""A real browser for the report page: Debian's headless Chromium, when installed.

``.ci/run`` installs it (``apt-get install chromium``); the tests that need it are
skipped where it is not.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from html.parser import HTMLParser
from pathlib import Path

__all__ = ["BROWSER", "Table", "dump_dom", "screenshot"]

#: The browser's command, or None.
BROWSER = next(
    (
        found
        for name in ("chromium", "chromium-browser", "google-chrome")
        if (found := shutil.which(name))
    ),
    None,
)


def _run(*args: str) -> str:
    assert BROWSER is not None
    with tempfile.TemporaryDirectory(prefix="harlsync-browser-") as profile:
        done = subprocess.run(
            [
                BROWSER,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--no-first-run",
                f"--user-data-dir={profile}",
                *args,
            ],
            capture_output=True,
            text=True,
            timeout=90,
            check=False,
        )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def dump_dom(page: Path) -> str:
    """The page's DOM after the browser rendered it, serialized."""
    return _run("--dump-dom", page.resolve().as_uri())


def screenshot(page: Path, out: Path, size: tuple[int, int] = (1400, 1000)) -> None:
    _run(
        f"--screenshot={out.resolve()}",
        f"--window-size={size[0]},{size[1]}",
        "--hide-scrollbars",
        page.resolve().as_uri(),
    )


class Table(HTMLParser):
    """The text of each cell of the table with ``id``, row by row, and every element
    name seen anywhere (to find a ``script`` that should not be there)."""

    def __init__(self, dom: str, id: str) -> None:
        super().__init__()
        self.id = id
        self.rows: list[list[str]] = []
        self.elements: set[str] = set()
        self.text: list[str] = []
        self._inside = 0
        self._cell: list[str] | None = None
        self.feed(dom)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.elements.add(tag)
        if tag == "table" and ("id", self.id) in attrs:
            self._inside = 1
        elif self._inside and tag == "tr":
            self.rows.append([])
        elif self._inside and tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if self._inside and tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append(" ".join("".join(self._cell).split()))
            self._cell = None
        elif tag == "table":
            self._inside = 0

    def handle_data(self, data: str) -> None:
        self.text.append(data)
        if self._cell is not None:
            self._cell.append(data)
