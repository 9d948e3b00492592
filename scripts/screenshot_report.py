"""Render an HTML report to PNG with a headless Chromium, to check how it reads.

    python scripts/screenshot_report.py REPORT.html [-o REPORT.png] [--size 1366,900]
                                        [--full-height PX]

Uses ``chromium`` (Debian: ``apt-get install chromium``), ``chromium-browser`` or
``google-chrome`` from PATH, or the one named by ``$CHROMIUM``. The browser runs with a new
empty profile in a temporary folder and no network features; the page itself loads nothing
from outside. ``--full-height PX`` uses a window PX pixels tall to capture a long page.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
)


def find_browser() -> str | None:
    """The Chromium executable to use, or None when there is none."""
    named = os.environ.get("CHROMIUM")
    if named:
        return shutil.which(named) or (named if Path(named).is_file() else None)
    return next((path for b in BROWSERS if (path := shutil.which(b))), None)


def _run(browser: str, args: list[str], timeout: float) -> subprocess.CompletedProcess:
    with tempfile.TemporaryDirectory(prefix="motionclean-chromium-") as profile:
        return subprocess.run(
            [browser, *FLAGS, f"--user-data-dir={profile}", *args],
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )


def screenshot(
    html_path: Path,
    png_path: Path,
    width: int = 1366,
    height: int = 900,
    browser: str | None = None,
    timeout: float = 60.0,
) -> Path:
    """Render ``html_path`` at ``width`` x ``height`` CSS pixels into ``png_path``."""
    browser = browser or find_browser()
    if browser is None:
        raise FileNotFoundError("no Chromium found (apt-get install chromium, or set $CHROMIUM)")
    png_path = png_path.resolve()
    png_path.unlink(missing_ok=True)
    done = _run(
        browser,
        [
            f"--screenshot={png_path}",
            f"--window-size={width},{height}",
            html_path.resolve().as_uri(),
        ],
        timeout,
    )
    if not png_path.is_file():
        raise RuntimeError(
            f"{browser} wrote no screenshot (exit {done.returncode}): {done.stderr.strip()[-500:]}"
        )
    return png_path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("report", type=Path, help="the HTML report to render")
    parser.add_argument("-o", "--output", type=Path, help="PNG to write (default: beside it)")
    parser.add_argument("--size", default="1366,900", help="window WIDTH,HEIGHT in CSS px")
    parser.add_argument(
        "--full-height",
        type=int,
        metavar="PX",
        default=None,
        help="use a window this tall, to capture a long page",
    )
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split(","))
    if args.full_height:
        height = args.full_height
    output = args.output or args.report.with_suffix(".png")
    try:
        written = screenshot(args.report, output, width, height)
    except (FileNotFoundError, RuntimeError, subprocess.TimeoutExpired) as error:
        print(f"screenshot_report: error: {error}", file=sys.stderr)
        return 1
    print(written)
    return 0


if __name__ == "__main__":
    sys.exit(main())
