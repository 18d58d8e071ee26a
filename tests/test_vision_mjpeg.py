"""The MJPEG stream opened by an independent client (OpenCV's FFmpeg backend), its snapshot,
and a slow client that never holds up `publish`."""

from __future__ import annotations

import socket
import threading
import time
import urllib.request

import cv2
import numpy as np
import pytest
from conftest import free_tcp_port, poll_until

from gazed.vision.mjpeg import MjpegServer


def frame(value: int) -> np.ndarray:
    image = np.zeros((120, 160, 3), np.uint8)
    image[:, :] = (value, 255 - value, 128)
    return image


@pytest.fixture
def server():
    with MjpegServer(port=free_tcp_port()) as running:
        yield running


def publish_until(server: MjpegServer, stop: threading.Event) -> None:
    value = 0
    while not stop.is_set():
        server.publish(frame(value % 256))
        value += 7
        stop.wait(0.02)


def test_opencv_reads_the_stream(server: MjpegServer) -> None:
    stop = threading.Event()
    publisher = threading.Thread(target=publish_until, args=(server, stop))
    publisher.start()
    try:
        capture = cv2.VideoCapture(server.url, cv2.CAP_FFMPEG)
        assert capture.isOpened()
        images = [capture.read() for _ in range(5)]
        capture.release()
    finally:
        stop.set()
        publisher.join()
    assert all(ok for ok, _ in images)
    assert all(image.shape == (120, 160, 3) for _, image in images)
    # the colour survives JPEG: red channel = 128 everywhere
    assert all(abs(float(image[..., 2].mean()) - 128) < 6 for _, image in images)


def test_snapshot_is_the_newest_frame(server: MjpegServer) -> None:
    snapshot = f"http://127.0.0.1:{server.port}/snapshot.jpg"
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(snapshot, timeout=5)
    assert refused.value.code == 503
    server.publish(frame(200))
    body = urllib.request.urlopen(snapshot, timeout=5).read()
    image = cv2.imdecode(np.frombuffer(body, np.uint8), cv2.IMREAD_COLOR)
    assert abs(float(image[..., 0].mean()) - 200) < 6


def test_a_client_that_stops_reading_does_not_hold_up_publish(server: MjpegServer) -> None:
    big = np.random.default_rng(0).integers(0, 256, (480, 640, 3), np.uint8)  # JPEG-hostile
    with socket.create_connection(("127.0.0.1", server.port), timeout=5) as stalled:
        stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled.sendall(b"GET /stream.mjpg HTTP/1.1\r\nHost: x\r\n\r\n")
        poll_until(lambda: server.clients == 1, 5.0)
        started = time.monotonic()
        for _ in range(200):  # far more than the socket buffers hold; the client reads nothing
            server.publish(big)
        assert time.monotonic() - started < 2.0
    poll_until(lambda: server.clients == 0, 5.0)


def test_a_port_in_use_is_an_error() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(OSError, match="cannot serve MJPEG"):
            MjpegServer(port=taken.getsockname()[1]).start()
