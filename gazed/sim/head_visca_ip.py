"""The camera's end of VISCA over IP (`gazed.servo.visca_ip`), for the head emulator: Sony's
header and sequence numbers around the VISCA camera of `head_visca`, which does all the command
handling.

- RESET (`02 00 .. 01`) forgets the last sequence number and is answered `02 01 .. 01` under
  the same number.
- A command or inquiry under the number it had last is a retransmission whose reply was lost:
  it is answered `0F 01` (abnormal sequence number) and not executed again (Sony p.32).
- Any other payload type is answered `0F 02`; a datagram that is not a message is dropped and
  counted.
- Replies carry the number of what they answer: ACK, error, inquiry reply and IF_Clear's
  completion that of the request that is next in line; a socket's completion that of the
  command whose ACK named the socket.
"""

from __future__ import annotations

from collections import Counter, deque

from gazed.servo import visca_ip
from gazed.servo.visca import TERMINATOR
from gazed.servo.visca_ip_transport import is_ack, is_completion


class ViscaIpSession:
    """Sony's framing on the camera side; bytes in and out, no I/O."""

    def __init__(self) -> None:
        self.counters: Counter[str] = Counter()
        self._last: int | None = None
        self._answering: deque[int] = deque()
        self._socket_sequence: dict[int, int] = {}
        self._partial = bytearray()

    def receive(self, datagram: bytes) -> tuple[bytes, list[bytes]]:
        """A datagram from the host -> (VISCA bytes for the camera, datagrams to send back)."""
        message = visca_ip.parse(datagram)
        if message is None:
            self.counters["garbage_datagrams"] += 1
            return b"", []
        control = visca_ip.PAYLOAD_TYPE["control_reply"]
        if message.payload_type == visca_ip.PAYLOAD_TYPE["control"]:
            if message.payload == visca_ip.RESET:
                self._last = None
                self.counters["resets"] += 1
                return b"", [visca_ip.frame(control, message.sequence, visca_ip.RESET_ACK)]
            return b"", [visca_ip.frame(control, message.sequence, visca_ip.MESSAGE_TYPE_ERROR)]
        if message.payload_type not in (
            visca_ip.PAYLOAD_TYPE["command"],
            visca_ip.PAYLOAD_TYPE["inquiry"],
        ):
            return b"", [visca_ip.frame(control, message.sequence, visca_ip.MESSAGE_TYPE_ERROR)]
        if message.sequence == self._last:
            self.counters["repeated_sequences"] += 1
            return b"", [visca_ip.frame(control, message.sequence, visca_ip.SEQUENCE_ERROR)]
        self._last = message.sequence
        self._answering.append(message.sequence)
        return message.payload, []

    def send(self, replies: bytes) -> list[bytes]:
        """The camera's reply bytes -> one datagram per reply, each under its number."""
        self._partial += replies
        out = []
        while (end := self._partial.find(TERMINATOR)) >= 0:
            packet = bytes(self._partial[: end + 1])
            del self._partial[: end + 1]
            sequence = self._sequence_of(packet)
            if sequence is None:
                self.counters["unattributed_replies"] += 1
                continue
            out.append(visca_ip.frame(visca_ip.PAYLOAD_TYPE["reply"], sequence, packet))
        return out

    def _sequence_of(self, packet: bytes) -> int | None:
        if is_completion(packet):
            return self._socket_sequence.pop(packet[1] & 0x0F, None)
        if not self._answering:
            return None
        sequence = self._answering.popleft()
        if is_ack(packet):
            self._socket_sequence[packet[1] & 0x0F] = sequence
        return sequence
