"""Real Chromium (Debian's /usr/bin/chromium) through Playwright for the
browser tests, and where their screenshots go: build/screenshots (ignored
by git), or ARGAND_SCREENSHOTS (`make screenshots` copies the pictures the
docs show from there into docs/screenshots)."""

from __future__ import annotations

import contextlib
import os
import shutil
from pathlib import Path
from typing import Iterator

import pytest

REPO = Path(__file__).resolve().parents[2]
SHOTS = Path(os.environ.get("ARGAND_SCREENSHOTS") or REPO / "build" / "screenshots")
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--disable-background-networking",
        "--disable-component-update", "--no-first-run", "--disable-sync"]


def shot(page, name: str) -> Path:
    """A full-page screenshot, SHOTS/<name>.png."""
    path = SHOTS / f"{name}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(path), full_page=True)
    return path


@contextlib.contextmanager
def chromium_page(offline_except: str | None = None) -> Iterator:
    """A page in a fresh Chromium, 1280x900; ``page.errors`` collects console
    errors and uncaught exceptions. With ``offline_except`` (an origin), every
    request elsewhere is aborted and listed in ``page.blocked``."""
    from playwright.sync_api import sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail("Chromium is missing: make setup installs Debian's chromium package (as root)")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            context = browser.new_context(viewport={"width": 1280, "height": 900})
            blocked: list[str] = []
            if offline_except is not None:
                def only_local(route):
                    if route.request.url.startswith(offline_except + "/") or route.request.url == offline_except:
                        route.continue_()
                    else:
                        blocked.append(route.request.url)
                        route.abort("internetdisconnected")
                context.route("**/*", only_local)
            pg = context.new_page()
            errors: list[str] = []
            pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.errors, pg.blocked = errors, blocked
            yield pg
        finally:
            browser.close()
