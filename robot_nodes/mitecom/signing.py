"""Signed team messages: a teammate's message is believed only if it carries the team's signature.

Team messages are UDP datagrams anyone on the field's Wi-Fi can send (other teams, visitors), and the HSL counts
every message on a team's port against its budget. A team that shares ``team.key`` (`pitchside team-keys`)
appends a trailer to each message, inside the 512 bytes the HSL allows:

    message | "PT" | version 1 | sender id (u8) | sent at, ms since the epoch (u64 LE) | tag (16 bytes)

The tag is HMAC-SHA256, cut to 128 bits, over the team number, the message and the trailer before the tag, under
a key derived from the team key with HKDF-SHA256 (its info names the team number, so one key file shared by two
teams, as `pitchside match` shares its run's key, still gives each team its own key). A receiver believes a message
only if the tag verifies, its time is later than every earlier one of that sender (a recorded message sent again
is refused) and within ``window_s`` of its own clock (a message recorded before the receiver started is refused
too; the team's machines keep their clocks within that, as `pitchside doctor` checks). A sender's times only grow
(the next millisecond if its clock stepped back).

Rejections, counted by reason: ``unsigned`` (no trailer), ``forged`` (the tag does not verify: another key, another
team, a changed byte), ``replayed`` (not newer than that sender's newest), ``stale`` (outside the window).
"""

from __future__ import annotations

import hashlib
import hmac
import struct
import time
from collections import Counter
from collections.abc import Callable

from cryptography.hazmat.primitives import hashes
from cryptography.hazmat.primitives.kdf.hkdf import HKDF

MARKER = b"PT"
VERSION = 1
_FIELDS = struct.Struct("<2sBBQ")
TAG_SIZE = 16
TRAILER_SIZE = _FIELDS.size + TAG_SIZE  # 28 bytes of the 512
_TEAM = struct.Struct("<H")
REASONS = ("unsigned", "forged", "replayed", "stale")


class SignatureError(Exception):
    """A team message that is not to be believed; ``reason`` is one of REASONS."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


def message_key(team_key: bytes, team_id: int) -> bytes:
    """The signing key of one team's messages, derived from the team key (never the team key itself, which also
    seals telemetry)."""
    return HKDF(algorithm=hashes.SHA256(), length=32, salt=None,
                info=b"pitchside team messages v1, team %d" % team_id).derive(team_key)


class TeamMessageSigner:
    """Signs this robot's messages and checks its teammates' for one team."""

    def __init__(self, team_key: bytes, team_id: int, sender_id: int, window_s: float = 30.0,
                 clock_s: Callable[[], float] = time.time) -> None:
        if not 0 <= sender_id <= 255:
            raise ValueError(f"sender id {sender_id} does not fit a byte")
        self._key = message_key(team_key, team_id)
        self._team = _TEAM.pack(team_id & 0xFFFF)
        self.sender_id = sender_id
        self.window_ms = int(window_s * 1000)
        self._clock_s = clock_s
        self._last_sent_ms = 0
        self._newest_ms: dict[int, int] = {}  # sender id -> time of its newest believed message

    def _tag(self, signed: bytes) -> bytes:
        return hmac.new(self._key, self._team + signed, hashlib.sha256).digest()[:TAG_SIZE]

    def sign(self, message: bytes) -> bytes:
        """The message with its trailer (TRAILER_SIZE bytes longer)."""
        sent_ms = max(int(self._clock_s() * 1000), self._last_sent_ms + 1)
        self._last_sent_ms = sent_ms
        signed = message + _FIELDS.pack(MARKER, VERSION, self.sender_id, sent_ms)
        return signed + self._tag(signed)

    def verify(self, datagram: bytes) -> tuple[int, bytes]:
        """(sender id, message) of a datagram a teammate signed; SignatureError says why it is not believed."""
        if len(datagram) < TRAILER_SIZE:
            raise SignatureError("unsigned", f"{len(datagram)} bytes, shorter than the signature")
        signed, tag = datagram[:-TAG_SIZE], datagram[-TAG_SIZE:]
        marker, version, sender, sent_ms = _FIELDS.unpack_from(signed, len(signed) - _FIELDS.size)
        if marker != MARKER or version != VERSION:
            raise SignatureError("unsigned", "no team signature at the end of the message")
        if not hmac.compare_digest(tag, self._tag(signed)):
            raise SignatureError("forged", f"the signature of sender {sender} does not verify under the team key")
        now_ms = int(self._clock_s() * 1000)
        if abs(now_ms - sent_ms) > self.window_ms:
            raise SignatureError("stale", f"sender {sender}'s message is {(now_ms - sent_ms) / 1000:+.1f} s old, "
                                          f"outside the {self.window_ms / 1000:.0f} s window (clocks apart?)")
        if sent_ms <= self._newest_ms.get(sender, 0):
            raise SignatureError("replayed", f"sender {sender}'s message of {sent_ms} ms is not newer than its "
                                             f"newest ({self._newest_ms[sender]} ms)")
        self._newest_ms[sender] = sent_ms
        return sender, signed[:-_FIELDS.size]


class TeamMessageGuard:
    """What the team communication node sends and believes: signed with a signer, plain without one (a mixed
    team's choice, or loopback only). Counts what it refuses by reason."""

    def __init__(self, signer: TeamMessageSigner | None) -> None:
        self.signer = signer
        self.rejected: Counter[str] = Counter()

    @property
    def mode(self) -> str:
        return "signed" if self.signer is not None else "unsigned"

    def outgoing(self, message: bytes) -> bytes:
        return self.signer.sign(message) if self.signer is not None else message

    def incoming(self, datagram: bytes) -> tuple[int | None, bytes]:
        """(the signer's sender id, or None unsigned; the message); SignatureError (counted) if refused."""
        if self.signer is None:
            return None, datagram
        try:
            return self.signer.verify(datagram)
        except SignatureError as exc:
            self.rejected[exc.reason] += 1
            raise
