"""The report renders in headless Chromium: figures decoded, 3D canvas drawn, play and the
time slider move the robot, and the console stays silent (no errors, no warnings).

Needs Debian's ``chromium``. Where it is missing the test is skipped with a visible reason,
except under CI (``CI`` set in the environment), which installs it: there a missing browser
fails the test, so a report is never passed without being opened in a browser.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.report.test_report import make_plan_dir

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--enable-logging=stderr",
    "--v=0",
)

# Test-side probe appended to a copy of the page: measures the canvas' drawn pixels, presses
# Play, moves the slider, and writes what it saw into data attributes of <body>.
PROBE = """<script>
window.addEventListener("load", function () {
  var root = document.getElementById("mmplan-viewer"), canvas = root.querySelector("canvas");
  var px = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data, ink = 0;
  for (var i = 0; i < px.length; i += 4) {
    if (px[i] < 245 || px[i + 1] < 245 || px[i + 2] < 245) ink++;
  }
  document.body.dataset.canvasInk = String(ink / (px.length / 4));
  document.body.dataset.canvasWidth = String(canvas.width);
  var viewer = window.mmplanViewer, az = viewer.azimuth, dist = viewer.distance;
  canvas.dispatchEvent(new MouseEvent("mousedown", {clientX: 100, clientY: 100}));
  window.dispatchEvent(new MouseEvent("mousemove", {clientX: 160, clientY: 90}));
  window.dispatchEvent(new MouseEvent("mouseup", {}));
  canvas.dispatchEvent(new WheelEvent("wheel", {deltaY: 300, cancelable: true}));
  document.body.dataset.orbit = String(viewer.azimuth !== az && viewer.distance > dist);
  root.querySelector("button.play").click();
  setTimeout(function () {
    document.body.dataset.frameAfterPlay = canvas.dataset.frame;
    var slider = root.querySelector("input[type=range]");
    slider.value = "100";
    slider.dispatchEvent(new Event("input"));
    document.body.dataset.frameAfterSlider = canvas.dataset.frame;
    document.body.dataset.timeLabel = root.querySelector(".time").textContent;
  }, 1500);
});
</script></body>"""


def _browser() -> str:
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    reason = "no chromium on PATH: install it (apt-get install -y chromium) to test the report"
    if os.environ.get("CI"):
        pytest.fail(reason)
    pytest.skip(reason)


def _run(browser: str, page: Path, profile: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            browser,
            *FLAGS,
            f"--user-data-dir={profile}",
            "--window-size=1200,2400",
            "--virtual-time-budget=6000",
            *extra,
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def _attr(dom: str, name: str) -> str:
    match = re.search(rf'<body[^>]*\bdata-{name}="([^"]*)"', dom)
    assert match is not None, f"<body data-{name}> missing: the page script did not run"
    return match.group(1)


def test_report_renders_in_headless_chromium(tmp_path: Path) -> None:
    from mmplan.report import write_report

    browser = _browser()
    folder = make_plan_dir(tmp_path / "plan", samples=401)
    report = write_report(folder, max_frames=201)  # every 2nd sample
    html = report.read_text()
    figures = html.count("<figure ")
    assert figures >= 10

    probed = folder / "probed.html"
    probed.write_text(html.replace("</body>", PROBE))
    run = _run(browser, probed, tmp_path / "profile", "--dump-dom")
    assert run.returncode == 0, run.stderr[-2000:]
    console = [line for line in run.stderr.splitlines() if "CONSOLE" in line]
    assert console == [], "console output:\n" + "\n".join(console)
    dom = run.stdout
    assert int(_attr(dom, "figures-loaded")) == figures  # every inline PNG decoded
    assert re.search(r'id="mmplan-viewer"[^>]*data-frames="201"', dom)
    assert int(_attr(dom, "canvas-width")) >= 320
    assert float(_attr(dom, "canvas-ink")) > 0.01  # grid, obstacles, paths, robot drawn
    played = int(_attr(dom, "frame-after-play"))
    assert abs(played - 37) <= 2  # 1.5 s of play at 1x: t = 1.5 s, frames 0.04 s apart
    assert _attr(dom, "frame-after-slider") == "100"
    assert _attr(dom, "orbit") == "true"  # drag orbits, wheel zooms out
    assert _attr(dom, "time-label").startswith("t = 4.00 s / 8.00 s")

    shot = folder / "report.png"
    run = _run(browser, report, tmp_path / "profile2", f"--screenshot={shot}")
    assert run.returncode == 0, run.stderr[-2000:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
