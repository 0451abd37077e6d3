"""The samples the live Zenoh source holds for the server's loop stay within a count and a byte bound."""

from __future__ import annotations

from server.sources.live import PendingSamples


def _sample(i: int, size: int) -> tuple[str, bytes, str, float | None]:
    return (f"pitchside/r1/t{i}", bytes(size), "application/cdr", None)


def test_large_payloads_are_bounded_by_bytes_keeping_the_newest() -> None:
    pending = PendingSamples(max_count=50_000, max_bytes=100_000)
    for i in range(1000):  # 20 MB offered: by count alone all of it would wait
        pending.append(_sample(i, 20_000))
    assert pending.bytes <= 100_000 and len(pending) == 5
    assert pending.dropped == 995
    assert [key for key, *_ in pending.take()] == [f"pitchside/r1/t{i}" for i in range(995, 1000)]
    assert len(pending) == 0 and pending.bytes == 0


def test_small_payloads_are_bounded_by_count() -> None:
    pending = PendingSamples(max_count=100, max_bytes=1 << 20)
    for i in range(250):
        pending.append(_sample(i, 10))
    assert len(pending) == 100 and pending.dropped == 150 and pending.bytes == 1000


def test_one_payload_larger_than_the_bound_still_goes_to_the_loop() -> None:
    pending = PendingSamples(max_count=10, max_bytes=1000)
    pending.append(_sample(0, 5000))
    assert len(pending) == 1  # the newest is kept: the hub decides what is too large, not this hand-over
    pending.append(_sample(1, 10))
    assert [key for key, *_ in pending.take()] == ["pitchside/r1/t1"]
