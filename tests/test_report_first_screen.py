"""The report's first screen (issue 48): the headline (generic -> tuned against the floor), the trajectory figure,
what tuning changed; sections that need repeats say so in one line for a single run; and the page in a real
browser (headless Chromium through Selenium, where the machine has them)."""

from __future__ import annotations

import csv
import re
import shutil
import warnings
from pathlib import Path

import pytest

from simtune.reference import REFERENCE_DIR
from simtune.report import make_report
from simtune.report.builder import ReportWarning
from simtune.report.sections import ONE_RUN
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore

ONLY = ["command_delay", "max_velocity_joint_2", "marker_offset_z"]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
CHROMEDRIVER = shutil.which("chromedriver")
BROWSER_INSTALL = "apt-get install chromium chromium-driver && pip install selenium"


@pytest.fixture(scope="module")
def one_run(tmp_path_factory) -> Path:
    """One short run of `cube` on the shipped reference recording, and its report."""
    root = tmp_path_factory.mktemp("first_screen")
    config = RunConfig(
        optimizer="de",
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        max_generations=2,
        only=ONLY,
    )
    start_run(config, root / "run", show_progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ReportWarning)
        make_report(root / "run", root / "report", show_progress=False)
    return root


def _rows(root: Path, name: str) -> list[dict]:
    return list(csv.DictReader((root / "report" / "tables" / f"{name}.csv").read_text().splitlines()))


def test_the_report_opens_with_the_headline_the_trajectory_and_what_changed(one_run):
    page = (one_run / "report" / "index.html").read_text()
    titles = re.findall(r"<h2>(.*?)</h2>", page)
    assert titles[0] == "1. At a glance" and titles[1].startswith("2. Generic")
    first = page[page.index('<section id="headline">') : page.index('<section id="generic">')]
    # in order: the headline table, the trajectory figure, the parameters
    assert first.index("tables/headline.csv") < first.index("figures/trajectory_mujoco_cube_extended_cube.png")
    assert first.index("figures/trajectory_mujoco_cube_extended_cube.png") < first.index("tables/tuned_parameters.csv")
    # the trajectories section shows the same figure, drawn once
    assert page.count('href="figures/trajectory_mujoco_cube_extended_cube.png"') == 2

    store = RunStore.open_read_only(one_run / "run")
    generic, best = store.get("generic")["fitness"], store.best_evaluation()["score"]["fitness"]
    store.close()
    (row,) = _rows(one_run, "headline")
    assert (row["engine"], row["space"], row["task"], row["runs"]) == ("mujoco", "extended", "cube", "1")
    assert float(row["generic fitness"]) == pytest.approx(generic) and float(row["tuned fitness"]) == pytest.approx(
        best
    )
    assert float(row["lower than generic [%]"]) == pytest.approx(100 * (1 - best / generic))
    assert float(row["tuned / floor"]) == pytest.approx(best / float(row["floor"]))

    moved = _rows(one_run, "tuned_parameters")
    assert sorted(r["parameter"] for r in moved) == sorted(ONLY)
    shares = [float(r["moved [% of range]"]) for r in moved]
    assert shares == sorted(shares, reverse=True)


def test_sections_that_need_repeats_say_so_in_one_line_for_a_single_run(one_run):
    page = (one_run / "report" / "index.html").read_text()
    importance = page[page.index('<section id="importance">') :]
    importance = importance[: importance.index("</section>")]
    assert ONE_RUN.split(":")[0] in importance and "<table" not in importance
    assert not (one_run / "report" / "tables" / "parameter_importance.csv").exists()


@pytest.mark.slow  # a browser end to end: 11 s
@pytest.mark.skipif(CHROMIUM is None or CHROMEDRIVER is None, reason=f"no Chromium here: {BROWSER_INSTALL}")
def test_the_report_in_a_browser_loads_without_errors_and_its_first_screen_holds_the_headline(one_run):
    webdriver = pytest.importorskip("selenium.webdriver", reason=f"selenium missing: {BROWSER_INSTALL}")
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--window-size=1280,900",
    ):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        driver.get((one_run / "report" / "index.html").as_uri())
        assert driver.title.startswith("simtune report")
        errors = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        assert errors == [], errors
        # every figure shown has loaded (an image the page embeds that the browser could not decode is 0 wide)
        images = driver.find_elements(By.TAG_NAME, "img")
        assert images and all(driver.execute_script("return arguments[0].naturalWidth", img) > 0 for img in images)
        tables = {p.stem for p in (one_run / "report" / "tables").glob("*.csv")}
        links = {a.get_attribute("href").rsplit("/", 1)[-1] for a in driver.find_elements(By.TAG_NAME, "a")}
        assert {f"{name}.csv" for name in tables} <= links
        # the first screen (900 px, the page scrolled to its top): the headline's title and the trajectory figure
        height = driver.execute_script("return window.innerHeight")
        headline = driver.find_element(By.ID, "headline")
        trajectory = headline.find_element(By.TAG_NAME, "img")
        assert headline.location["y"] < height
        assert trajectory.location["y"] < 2 * height, "the trajectory figure starts within two screens"
    finally:
        driver.quit()
