"""The web view in a real browser (headless Chromium, the Debian package, driven by
playwright): the catalogue's count of a running sweep rises without a reload, the sweep
page's map is an image the browser decoded, a CSV downloaded from the page equals
``ditherlab query``, the explorer draws a chart, and no page logs an error (the CSP lets
the page's own scripts run). Screenshots go to ``$DITHERLAB_SCREENSHOTS`` (default: the
test's temporary folder).

Without playwright or the browser the test is skipped, except under ``CI=true``, where it
fails saying what is missing (``.ci/run`` installs both).
"""
from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import pytest

from ..helpers import ditherlab
from ..sweeps.web.conftest import RUNNING_ID

pytestmark = [pytest.mark.long, pytest.mark.browser, pytest.mark.subprocess]   # a real browser

CHROMIUM = os.environ.get("DITHERLAB_CHROMIUM", "/usr/bin/chromium")
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-default-apps", "--no-first-run",
        "--disable-extensions", "--disable-sync", "--metrics-recording-only"]


def _browser_or_reason():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return None, "playwright is not installed (pip install -e '.[web-test]')"
    if not (shutil.which(CHROMIUM) or Path(CHROMIUM).is_file()):
        return None, f"no browser at {CHROMIUM} (apt-get install chromium)"
    return sync_playwright, None


@pytest.fixture
def browser():
    sync_playwright, reason = _browser_or_reason()
    if reason:
        if os.environ.get("CI") == "true":
            pytest.fail(f"the browser test cannot run under CI=true: {reason}")
        pytest.skip(reason)
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        yield b
        b.close()


@pytest.fixture
def shots(tmp_path) -> Path:
    folder = Path(os.environ.get("DITHERLAB_SCREENSHOTS") or tmp_path / "screenshots")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def test_the_pages_in_a_browser(browser, server, web_store, running, shots, tmp_path):
    from playwright.sync_api import expect

    base, ctx = server
    ctx.live.refresh_s = 0
    page = browser.new_page(viewport={"width": 1400, "height": 1000}, accept_downloads=True)
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))

    # catalogue: the running sweep's count rises in place (no navigation happens)
    running.advance(10)
    page.goto(base + "/")
    cell = page.locator(f'tr[data-id="{RUNNING_ID}"] [data-f="done_points"]')
    assert cell.inner_text() == "10"
    page.evaluate("window.__same_document = true")
    running.advance(30)
    # expect() polls through selectors: wait_for_function would eval a string, which the
    # page's CSP forbids (as it should)
    expect(cell).to_have_text("40", timeout=15000)
    assert page.evaluate("window.__same_document") is True   # not reloaded
    page.screenshot(path=str(shots / "catalogue.png"), full_page=True)

    # sweep page: open it from the catalogue; its maps decode
    page.click(f'a[href="/sweep/{web_store["avg"]}"]')
    page.wait_for_load_state("networkidle")
    widths = page.eval_on_selector_all("img.mapimg", "imgs => imgs.map(i => i.naturalWidth)")
    assert len(widths) == 2 and all(w > 0 for w in widths), widths
    page.screenshot(path=str(shots / "sweep.png"), full_page=True)

    # a CSV download from the page's form equals `ditherlab query --format csv`
    page.fill('input[name="sel.v_d"]', "0.1")
    with page.expect_download() as dl:
        page.click("#dl-csv")
    got = Path(dl.value.path()).read_bytes()
    cli = ditherlab("query", web_store["avg"], "--format", "csv", "--sel", "v_d=0.1",
                    "--store", str(web_store["root"]), text=False)
    assert got == cli.stdout and got.count(b"\n") == 21 * 25 + 1

    # the explorer: a click computes and shows a chart
    page.goto(base + "/explorer")
    page.fill('input[name="W_num"]', "60")
    page.fill('input[name="v_ref_num"]', "60")
    page.click("#compute")
    expect(page.locator("#explorer-status")).to_have_text(re.compile("^click to image"),
                                                          timeout=120000)
    assert page.evaluate("document.getElementById('chart').naturalWidth") > 0
    page.click("#submit-toml summary")   # "submit this as a sweep": the TOML to paste
    toml = page.inner_text("#submit-toml pre")
    assert 'method = "averaged"' in toml and "W = { start = 0.0, stop = 1.2, num = 60 }" in toml
    page.screenshot(path=str(shots / "explorer.png"), full_page=True)
    assert errors == []
