"""`gazed view --rig RIG`: the live view of a running rig in the browser.

Serves the page on the rig's `[view]` address (its defaults without one: loopback, 8091) and
joins the rig's bus as a client. `gazed run` starts it as one more supervised process,
`python -m gazed.view.view_cli --rig RIG`, when the rig has a `[view]`: a process of its own,
so that encoding JPEG and serving browsers never takes the loop's or the supervisor's CPU time
under one interpreter lock, and a crash of the page restarts only the page.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
import sys
from pathlib import Path

from aiohttp import web

from gazed.backoff import Backoff
from gazed.config import Rig, load_rig_or_exit
from gazed.config.view import ViewError, ViewSection
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.view.bus_link import ViewLink
from gazed.view.frame_feed import FrameFeed
from gazed.view.live_state import LiveState
from gazed.view.projection import ImageProjection
from gazed.view.server import ViewServer

log = logging.getLogger("gazed.view")

LISTEN_RETRY_INITIAL_S = 1.0
LISTEN_RETRY_MAX_S = 10.0


def view_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", type=Path, required=True, help="rig file: its bus and [view]")
    parser.add_argument("--port", type=int, help="port of the page (default: the rig's [view])")
    parser.set_defaults(supervised=False)


def view_command(args: argparse.Namespace) -> int:
    logging.basicConfig(
        level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    rig = load_rig_or_exit(args.rig)
    view = rig.view
    if args.port is not None:
        view = view.model_copy(update={"port": args.port})
    folder = rig.source_path.parent if rig.source_path is not None else Path.cwd()
    try:
        password = view.password(folder)
    except ViewError as exc:
        print(f"gazed view: {exc}", file=sys.stderr)
        return 2
    try:
        return asyncio.run(serve(rig, view, password, args.supervised))
    except OSError as exc:
        print(f"gazed view: cannot serve on {view.host}:{view.port}: {exc}", file=sys.stderr)
        return 1


async def serve(
    rig: Rig, view: ViewSection, password: str | None, keep_trying: bool = False
) -> int:
    """Serve the page until SIGTERM or SIGINT."""
    loop = asyncio.get_running_loop()
    projection = ImageProjection(
        CameraModel.from_section(rig.camera),
        HeadKinematics.from_section(rig.head),
        rig.vision.fovea_rad,
    )
    state = LiveState(projection)
    feed = FrameFeed(view.jpeg_quality)
    link = ViewLink(rig, state, feed, loop)
    server = ViewServer(
        state,
        feed,
        link.publish_select,
        link.publish_command,
        password=password,
        state_period_s=1.0 / view.state_rate_hz,
        on_clients=lambda pages: link.watch(pages > 0),
    )
    stop = asyncio.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(signum, stop.set)
    runner = web.AppRunner(server.app(), handle_signals=False, access_log=None)
    await runner.setup()
    connecting = asyncio.create_task(link.connect())
    try:
        if await _listen(runner, view, stop, keep_trying):
            log.info("rig %s: the live view is on http://%s:%d/", rig.name, view.host, view.port)
            await stop.wait()
    finally:
        connecting.cancel()
        await runner.cleanup()
        link.close()
    return 0


async def _listen(
    runner: web.AppRunner, view: ViewSection, stop: asyncio.Event, keep_trying: bool
) -> bool:
    """Listen on the view's address; False if stopped first. An address in use raises
    OSError, or, with `keep_trying` (under the supervisor: a page that cannot listen must not
    take the rig down through restarts), is tried again until it is free."""
    backoff = Backoff(LISTEN_RETRY_INITIAL_S, LISTEN_RETRY_MAX_S)
    while True:
        try:
            await web.TCPSite(runner, view.host, view.port).start()
            return True
        except OSError as exc:
            if not keep_trying:
                raise
            log.error("cannot serve on %s:%d (%s); trying again", view.host, view.port, exc)
        try:
            await asyncio.wait_for(stop.wait(), backoff.next_delay_s())
            return False
        except TimeoutError:
            continue


if __name__ == "__main__":  # as the supervisor starts it
    from services.runtime import die_with_supervisor

    die_with_supervisor()
    parser = argparse.ArgumentParser(prog="gazed.view.view_cli")
    view_arguments(parser)
    parser.set_defaults(supervised=True)
    raise SystemExit(view_command(parser.parse_args()))
