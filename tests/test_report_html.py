"""`ncsim report`: one self-contained HTML page, checked in a real headless browser.

The browser is Debian's Chromium with its chromedriver (``apt-get install chromium
chromium-driver``; ``.ci/run`` installs them where it can), driven by selenium with every
network request blocked: the page must render from the file alone. Where no Chromium can be
had the browser test is skipped, saying so; the checks on the file itself always run."""
from __future__ import annotations

import re
import shutil

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli

THWS = "data/real/thws-spinner-u5-620-nc-programs/Bottle_opener_Flaschenoeffner.txt"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run",
         # WebGL (the 3-D view) in software, without a GPU
         "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--window-size=1400,1800")


@pytest.fixture(scope="module")
def page(shared, tmp_path_factory):
    out = tmp_path_factory.mktemp("html") / "report.html"
    r = CliRunner().invoke(cli, ["report", str(shared / THWS), "--machine", "mikron", "-o",
                                 str(out), "--quiet"])
    assert r.exit_code == 0, r.output
    assert r.stdout.startswith(f"wrote {out}: ")
    return out


def test_the_file_is_self_contained(page):
    text = page.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    assert not re.search(r"<script[^>]+src=", text)                 # plotly.js inlined
    assert not re.search(r"<link[^>]+href=[\"']?https?:", text)
    assert text.count("Plotly.newPlot") == 2
    for name in ("3D_ADAPTIVE_ROUGHING", "SCHAFT_D8_N_AP20", "N640-N15600"):
        assert name in text


def test_bad_output_name_is_one_line():
    r = CliRunner().invoke(cli, ["report", "programs/bore_d25_f5984.mpf", "-m", "mikron", "-o",
                                 "report.png"])
    assert r.exit_code == 2 and "the report is an HTML file" in r.stderr


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    if not (CHROMIUM and CHROMEDRIVER):
        pytest.skip("no Chromium with chromedriver on this machine (apt-get install chromium "
                    "chromium-driver): the page is not checked in a browser")
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium (the test extra) "
                                    "is not installed: pip install '.[test]'")
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    driver.set_script_timeout(60)
    try:
        driver.execute_cdp_cmd("Network.enable", {})
        driver.execute_cdp_cmd("Network.setBlockedURLs", {"urls": ["http://*", "https://*", "ws*"]})
        yield driver
    finally:
        driver.quit()


def test_page_renders_offline_and_names_the_blocks(page, browser):
    browser.get(page.as_uri())
    browser.execute_async_script(
        "const done = arguments[0];"
        "const wait = () => (document.querySelectorAll('.plot-container').length == 2"
        " && document.querySelector('#toolpath canvas')) ? done(true) : setTimeout(wait, 100);"
        "wait();")
    # nothing was fetched: every resource of the page is the file itself
    assert browser.execute_script("return performance.getEntriesByType('resource').length") == 0
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert errors == []
    # the 3-D toolpath: a WebGL scene, its points named by block
    text = browser.execute_script("return document.getElementById('toolpath').data[0].text")
    named = [t for t in text if t and "3D_ADAPTIVE_ROUGHING<" in t]
    assert named and re.match(r"Bottle_opener_Flaschenoeffner\.txt:\d+  N\d+<br>SCHAFT_D8_N_AP20 \| "
                              r"3D_ADAPTIVE_ROUGHING<br>[a-z_]+$", named[0])
    assert browser.execute_script("return !!document.getElementById('toolpath')._fullLayout.scene")
    # hovering the feed trace shows the block's label
    k = browser.execute_script(
        "const d = document.getElementById('feed').data[0];"
        "return d.text.findIndex(t => t && t.includes('WALL_PROFILING'));")
    assert k >= 0
    hover = browser.execute_async_script(
        "const done = arguments[0]; const gd = document.getElementById('feed');"
        f"const d = gd._fullData[0]; Plotly.Fx.hover(gd, {{xval: d.x[{k}], yval: d.y[{k}]}}, 'xy');"
        "let n = 0; const look = () => { const h = gd.querySelector('.hovertext');"
        " if (h || n++ > 50) done(h ? h.textContent : null); else setTimeout(look, 100); };"
        "look();")
    assert hover and "Bottle_opener_Flaschenoeffner.txt:" in hover
    assert "SCHAFT_D4_N_AP20 | WALL_PROFILING" in hover and re.search(r"feed \d+ of F 263 mm/min", hover)
    # the tables by operation and tool
    cells = browser.execute_script("return [...document.querySelectorAll('td')].map(c => c.textContent)")
    assert {"3D_ADAPTIVE_ROUGHING", "CURVE_DRIVE", "ENTFRAESER_D8_90GRAD"} <= set(cells)
