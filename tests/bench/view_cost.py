"""The live view's cost to the loop: processing latency p50/p99 and CPU with one page open
against none, side by side (tests/bench/loop_cost.py says how each is measured).

    python tests/bench/view_cost.py [--seconds 20] [--rounds 2] [--client browser|socket] [--json]

The rig is the sim rig with a `[view]`, so `gazed run` serves the page throughout; a phase
"with" opens one page: the system's headless Chromium through Selenium (`browser`, the
default where it is installed), or a WebSocket client that acknowledges every frame at once
(`socket`: the fastest reader there can be, so the most frames the view sends).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import shutil
import socket
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

import aiohttp
from loop_cost import measure, sim_rig, summary


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def browser_page(url: str) -> Iterator[None]:
    from selenium import webdriver

    options = webdriver.ChromeOptions()
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu"):
        options.add_argument(argument)
    service = webdriver.ChromeService(executable_path=shutil.which("chromedriver"))
    driver = webdriver.Chrome(options=options, service=service)
    try:
        driver.get(url)
        yield
        print(f"  page drew {driver.execute_script('return window.gazedView.framesShown')} frames")
    finally:
        driver.quit()


@contextlib.contextmanager
def socket_page(url: str) -> Iterator[None]:
    stop = threading.Event()
    frames = [0]

    async def read() -> None:
        async with aiohttp.ClientSession() as session, session.ws_connect(f"{url}ws") as ws:
            while not stop.is_set():
                try:
                    message = await asyncio.wait_for(ws.receive(), 0.5)
                except TimeoutError:
                    continue
                if message.type == aiohttp.WSMsgType.BINARY:
                    frames[0] += 1
                    await ws.send_json({"type": "ack"})

    thread = threading.Thread(target=lambda: asyncio.run(read()), daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(5)
        print(f"  the client took {frames[0]} frames")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=20.0, help="length of each phase")
    parser.add_argument("--rounds", type=int, default=2, help="pairs of phases")
    default_client = "browser" if shutil.which("chromedriver") else "socket"
    parser.add_argument("--client", choices=("browser", "socket"), default=default_client)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="view-cost-") as directory:
        port = free_port()
        rig_path = sim_rig(Path(directory), f"\n[view]\nport = {port}\n")
        url = f"http://127.0.0.1:{port}/"
        page = browser_page if args.client == "browser" else socket_page
        phases = []
        for phase in measure(rig_path, lambda: page(url), args.seconds, args.rounds):
            phases.append(phase)
            print(json.dumps(phase), flush=True)
    print(json.dumps(phases) if args.json else f"client: {args.client}\n{summary(phases)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
