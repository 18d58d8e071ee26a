"""The live view in a real browser: the system's headless Chromium, driven by Selenium, against
the running sim rig with a `[view]`. Frames arrive and overlays are drawn, a click on the target
reaches `gaze/select` with the head pose of the frame clicked, the park button parks the head
(`gaze/command` to the gaze, its state back on the page) until resume, and the page reconnects
by itself when the view's process restarts."""

from __future__ import annotations

import os
import shutil
import signal
from pathlib import Path
from typing import Any

import pytest
from conftest import REPO, RunningSupervisor, free_tcp_port, poll_until

from gazed.eval.private_rig import private_rig
from gazed.messages import GazeCommand, GazeSelect, GazeState
from gazed.topics import GAZE_COMMAND, GAZE_SELECT, GAZE_STATE

pytestmark = pytest.mark.e2e

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
if CHROMIUM is None or CHROMEDRIVER is None:
    pytest.skip(
        "no headless Chromium here (apt-get install chromium chromium-driver; .ci/run does)",
        allow_module_level=True,
    )


def browser() -> Any:
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,900"):
        options.add_argument(argument)
    service = webdriver.ChromeService(executable_path=CHROMEDRIVER)
    return webdriver.Chrome(options=options, service=service)


def test_the_page_shows_frames_and_overlays_and_a_click_selects(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 1, None)
    port = free_tcp_port()
    rig_path.write_text(rig_path.read_text() + f"\n[view]\nport = {port}\n")
    supervisor = RunningSupervisor(rig_path, tmp_path)
    driver = None
    try:
        supervisor.wait_ready(60.0)
        selections = supervisor.bus.subscribe(GAZE_SELECT)
        commands = supervisor.bus.subscribe(GAZE_COMMAND)
        states = supervisor.bus.subscribe(GAZE_STATE, capacity=256)
        driver = browser()
        driver.get(f"http://127.0.0.1:{port}/")
        view = lambda script: driver.execute_script(f"return window.gazedView.{script}")  # noqa: E731

        poll_until(lambda: view("framesShown") >= 5, 30.0, 0.1)
        # the target is found and drawn over the frame, with the fovea and the prediction
        overlay = poll_until(
            lambda: (
                (o := view("frame.meta.overlay"))["detection"] and o["detection"]["found"] and o
            ),
            30.0,
            0.1,
        )
        assert view("overlaysDrawn") >= 1
        assert overlay["fovea"]["side"] > 0
        # the map: the tracks, where they are predicted to be, and their uncertainty
        drawn = poll_until(
            lambda: (d := view("mapDrawn"))["tracks"] and d["predictions"] and d, 30.0, 0.1
        )
        assert drawn["ellipses"] >= 1
        assert driver.find_element("id", "gaze-reason").text.startswith("(")  # the state's reason
        assert driver.find_element("id", "gaze-state").text in (
            "saccade",
            "pursuit",
            "search",
            "lost",
        )

        # a click on the target, in the page's own coordinates
        u, v = overlay["detection"]["u"], overlay["detection"]["v"]
        seq = view("frame.meta.seq")
        driver.execute_script(
            """const c = document.getElementById('frame'), box = c.getBoundingClientRect();
            c.dispatchEvent(new MouseEvent('click', {bubbles: true,
              clientX: box.left + arguments[0] * box.width / c.width,
              clientY: box.top + arguments[1] * box.height / c.height}));""",
            u,
            v,
        )
        chosen: list[GazeSelect] = []
        poll_until(lambda: chosen.extend(selections.take()) or chosen, 10.0, 0.05)
        selection = chosen[0]
        assert selection.pixel_px is not None and selection.head is not None
        assert abs(selection.pixel_px[0] - u) < 2 and abs(selection.pixel_px[1] - v) < 2
        assert view("frame.meta.seq") >= seq
        poll_until(lambda: view("selected") and view("selected.ok"), 10.0, 0.05)
        assert driver.find_element("id", "selected").text == "selected"
        target_text = driver.find_element("id", "target-id").text
        target_id = view("state.target_id")
        assert target_text == ("—" if target_id is None else str(target_id))
        screenshot = tmp_path / "view.png"
        assert driver.save_screenshot(str(screenshot))
        assert screenshot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

        # park: the gaze parks the head and says so, with the operator as the reason
        text = lambda element_id: driver.find_element("id", element_id).text  # noqa: E731
        driver.find_element("css selector", "button[data-command=park]").click()
        sent: list[GazeCommand] = []
        poll_until(lambda: sent.extend(commands.take()) or sent, 10.0, 0.05)
        assert [c.command for c in sent] == ["park"]
        poll_until(lambda: text("gaze-state") == "park", 10.0, 0.05)
        assert text("gaze-reason") == "(operator: park)"
        assert text("commanded") == "park sent"
        park = driver.find_element("css selector", "button[data-command=park]")
        assert park.get_attribute("aria-pressed") == "true"
        seen: list[GazeState] = []
        parked = poll_until(
            lambda: seen.extend(states.take()) or [s for s in seen if s.state == "park"], 10.0
        )
        assert parked[0].reason == "operator: park"
        # resume: following again, from a search
        driver.find_element("css selector", "button[data-command=resume]").click()
        resumed = poll_until(
            lambda: seen.extend(states.take()) or [s for s in seen if "resume" in s.reason], 10.0
        )
        assert (resumed[0].previous, resumed[0].state) == ("park", "search")
        poll_until(lambda: text("gaze-state") != "park", 10.0, 0.05)
        assert park.get_attribute("aria-pressed") == "false"

        # the view's process dies; the supervisor restarts it and the page reconnects by itself
        shown = view("framesShown")
        os.kill(supervisor.pids()["view"], signal.SIGKILL)
        poll_until(lambda: driver.find_element("id", "connection").text != "connected", 10.0, 0.05)
        poll_until(lambda: driver.find_element("id", "connection").text == "connected", 30.0, 0.1)
        poll_until(lambda: view("framesShown") > shown + 5, 30.0, 0.1)
    finally:
        if driver is not None:
            driver.quit()
        assert supervisor.stop() == 0
