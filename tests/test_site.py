"""The documentation site (mkdocs.yml): ``mkdocs build --strict`` passes, so no link is broken, no page is missing
from the nav, no docstring reference names nothing and every figure a page asks for is in the outputs; the pages
hold what they are built from (the API reference, the notebooks with their outputs, the tables rendered from the
report's and the audit's files); and headless Chromium shows the landing page and an API page whole.

The notebooks are not run again: tests/test_notebooks.py leaves its executed copies for the build (one xdist
group, the notebooks first; tools/site/hooks.py runs any that are missing)."""

from __future__ import annotations

import functools
import http.server
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from fitlab.report.pareto import RULES

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools" / "site"))

import figures  # noqa: E402
import hooks  # noqa: E402
from crossrefs import resolve  # noqa: E402

SITE_GROUP = pytest.mark.xdist_group("notebooks-and-site")  # as in tests/test_notebooks.py
#: where the Chromium test leaves its screenshots (a temporary folder unless set)
SCREENSHOTS = os.environ.get("FITLAB_SCREENSHOTS")
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)}
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)  # fmt: skip
    assert run.returncode == 0, run.stderr[-4000:]
    return out


@pytest.mark.e2e
@SITE_GROUP
def test_the_site_builds_strict_with_every_page(site):
    pages = {p.relative_to(site).as_posix() for p in site.rglob("index.html")}
    for page in (
        "index.html",
        "getting_started/index.html",
        "api/store/index.html",
        "reference/cli/index.html",
        "reference/fit_schema/index.html",
        "accuracy/index.html",
        "notebooks/04_brdf/index.html",
    ):
        assert page in pages, f"the site has no {page}"
    for path in site.rglob("*.html"):
        text = path.read_text()
        outside_code = re.sub(r"<(pre|code)[^>]*>.*?</\1>", "", text, flags=re.S)
        assert "{{" not in outside_code, f"{path}: a figure left unrendered"
    # the API reference holds every public function the modules export, from their docstrings
    store = (site / "api" / "store" / "index.html").read_text()
    for name in ("load", "read_fit", "write_fit", "check_fit"):
        assert f'id="fitlab.store.{name}"' in store, f"the API reference lacks fitlab.store.{name}"
    # the notebooks with their outputs: the plots as images
    nb = (site / "notebooks" / "04_brdf" / "index.html").read_text()
    assert len(re.findall(r'<img [^>]*src="data:image/png;base64', nb)) >= 3
    # the recommendations rendered from the report's CSV, the same text as the README's table
    assert figures.use_table().splitlines()[2].split("|")[2].strip() in (site / "index.html").read_text()


def test_an_unknown_or_wrong_figure_fails_the_build():
    from mkdocs.exceptions import PluginError

    assert hooks.expand("no figure here") == "no figure here"
    assert hooks.expand("{{ report_value('exact engine', 'max_rel') }}").startswith(("1", "2", "3", "4", "5"))
    for bad in (
        "{{ nope() }}",
        "{{ report_value('no such method', 'max_rel') }}",
        "{{ report_value(os) }}",
        "{{ audit_value('runtime_true', 'nothing', 'max_rel') }}",
    ):
        with pytest.raises(PluginError):
            hooks.expand(bad)


def test_pages_named_by_path_become_links_outside_code():
    text = (
        'see docs/model.md, "H"; `docs/audit.md`; `x docs/report.md`\n```\ndocs/model.md\n```\n'
        "[a](model.md) docs/none.md docs/discover/H0.md\n"
    )
    got = hooks.link_mentions(text, "reference/cli.md", {"model.md", "audit.md", "report.md", "discover/H0.md"})
    assert got == (
        'see [docs/model.md](../model.md), "H"; [`docs/audit.md`](../audit.md); `x docs/report.md`\n'
        "```\ndocs/model.md\n```\n[a](model.md) docs/none.md [docs/discover/H0.md](../discover/H0.md)\n"
    )


def test_figures_print_as_stated():
    assert figures.sci(4.876e-4) == "4.9e-4" and figures.sci(2.32e-15) == "2.3e-15" and figures.sci(13.35) == "1.3e1"
    assert figures.sci(float("inf")) == "inf" and figures.sci(0.0) == "0"
    assert figures.time_ns(208.4) == "208 ns" and figures.time_ns(1848.0) == "1.85 us"
    assert figures.time_ns(1.23e6) == "1.23 ms"


def test_docstring_references_resolve_from_where_they_are_written():
    """The griffe extension's rule (tools/site/crossrefs.py) on fitlab itself: relative references start from the
    module's package, as imports do; a name that is not there resolves to nothing."""
    import griffe

    root = griffe.load("fitlab", search_paths=[str(ROOT)], resolve_aliases=False)
    report = root["report"]  # a package: its references start from itself
    assert resolve(root, report, ".pareto") == "fitlab.report.pareto"
    assert resolve(root, root["report.write"], ".pareto.recommend") == "fitlab.report.pareto.recommend"
    assert resolve(root, root["report.write"], "..store.load") == "fitlab.store.load"
    assert resolve(root, root["report.write"], "recommend") == ""  # not a name of its module: left as code
    assert resolve(root, root["store"], "fitlab.store.load") == "fitlab.store.load"
    assert resolve(root, root["store"], "fitlab.store.no_such_name") is None
    assert resolve(root, root["store"], "numpy.ndarray") == ""
    assert resolve(root, root["store"], "fitlab.fit_table") == "fitlab.fit.user.fit_table"
    assert resolve(root, root["core"], ".no_such_module") is None


def _serve(folder: Path):
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(folder))
    handler.log_message = lambda *a, **k: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


@pytest.mark.e2e
@SITE_GROUP
def test_chromium_shows_the_landing_page_and_an_api_page(site, tmp_path):
    if CHROMIUM is None:
        pytest.skip("no chromium (Debian package chromium; tools/install-system-packages.sh installs it)")
    sync_playwright = pytest.importorskip("playwright.sync_api").sync_playwright
    shots = Path(SCREENSHOTS) if SCREENSHOTS else tmp_path
    shots.mkdir(parents=True, exist_ok=True)
    server = _serve(site)
    base = f"http://127.0.0.1:{server.server_address[1]}"
    # the flags that keep Chromium off the network and its sandbox (run as root here)
    args = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
            "--disable-component-update", "--disable-sync"]  # fmt: skip
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=args)
            page = browser.new_page(viewport={"width": 1280, "height": 1600})
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(f"{base}/index.html", wait_until="networkidle")
            assert page.title().startswith("fitlab")
            # the figure drawn, not a broken image; the table of jobs has a row per use the report picks for
            figure = page.locator("img[src$='accuracy_vs_cost.png']")
            assert figure.count() == 1
            assert figure.evaluate("img => img.complete && img.naturalWidth > 600")
            rows = page.locator("table").first.locator("tbody tr")
            assert rows.count() == len(RULES)
            page.screenshot(path=str(shots / "landing.png"), full_page=False)

            page.goto(f"{base}/api/store/index.html", wait_until="networkidle")
            heading = page.locator("[id='fitlab.store.load']")
            assert heading.count() == 1 and heading.first.is_visible()
            assert "self-contained" in page.locator("article").inner_text()
            page.screenshot(path=str(shots / "api_store.png"), full_page=False)

            page.goto(f"{base}/notebooks/04_brdf/index.html", wait_until="networkidle")
            plots = page.locator("article img[src^='data:image/png']")
            assert plots.count() >= 3
            assert plots.first.evaluate("img => img.complete && img.naturalWidth > 100")
            plots.first.scroll_into_view_if_needed()
            page.screenshot(path=str(shots / "notebook_brdf.png"), full_page=False)
            browser.close()
    finally:
        server.shutdown()
    assert not errors, errors
