"""Adapters around dynamixel-sdk 4.1.0: a port that waits instead of spinning, a working P1 bulk read,
and a status receiver that keeps every good packet when one device is silent or garbled.

Why: in 4.1.0 `GroupBulkRead.txPacket` passes a `fast_option` argument that
`Protocol1PacketHandler.bulkReadTx` does not accept (TypeError on every P1 bulk read), and both
`GroupBulkRead.rxPacket` and `GroupSyncRead.rxPacket` give up at the first device that does not
answer, throwing away the packets of all devices after it. tests/test_dynamixel_backend.py has a
canary test that fails once the SDK changes, so this adapter gets revisited.
"""

from __future__ import annotations

import select
from dataclasses import dataclass, field
from typing import Any

from dynamixel_sdk import COMM_NOT_AVAILABLE, COMM_RX_CORRUPT, COMM_SUCCESS, GroupBulkRead, GroupSyncRead, PortHandler

SDK_VERSION_WORKED_AROUND = "4.1.0"


class BusPort(PortHandler):
    """PortHandler whose reads wait on the file descriptor (<= 2 ms) instead of busy-polling it.

    The SDK's receive loops call readPort as fast as they can while waiting for a status packet;
    blocking briefly in select() gives the CPU (and, with an in-process emulator, the GIL) away.
    """

    def readPort(self, length: int) -> bytes:
        ser = self.ser
        if ser.in_waiting == 0:
            remaining_s = (self.packet_timeout - self.getTimeSinceStart()) / 1000.0
            wait = min(max(remaining_s, 0.0), 0.002)
            if wait > 0.0:
                select.select([ser.fileno()], [], [], wait)
        return ser.read(length)


@dataclass(slots=True)
class StatusBatch:
    """What came back for one broadcast read: data per device that answered correctly."""

    data: dict[int, bytes] = field(default_factory=dict)
    errors: dict[int, int] = field(default_factory=dict)  # status error byte per device (non-zero only)
    corrupt: int = 0  # packets with bad checksum/CRC or wrong length
    timed_out: bool = False


def receive_statuses(ph: Any, port: PortHandler, lengths: dict[int, int], max_corrupt: int = 0) -> StatusBatch:
    """Collect one status packet per expected id until all arrived or the port's packet timeout expires
    (or, with max_corrupt > 0, that many garbled packets came).

    Packets are matched by id, not by position, so a silent device costs only its own data.
    """
    batch = StatusBatch()
    p2 = ph.getProtocolVersion() == 2.0
    try:
        while len(batch.data) < len(lengths):
            if port.isPacketTimeout():
                batch.timed_out = True
                break
            packet, result = ph.rxPacket(port, False) if p2 else ph.rxPacket(port)
            if result == COMM_RX_CORRUPT:
                batch.corrupt += 1
                if max_corrupt and batch.corrupt >= max_corrupt:
                    break
                continue
            if result != COMM_SUCCESS:
                batch.timed_out = True
                break
            dxl_id = packet[4] if p2 else packet[2]
            expected = lengths.get(dxl_id)
            if expected is None or dxl_id in batch.data:
                continue  # a stale or duplicate answer
            if p2:
                n = (packet[5] | packet[6] << 8) - 4  # LEN = params + instruction + error + CRC
                start, err = 9, packet[8]
            else:
                n = packet[3] - 2  # LEN = params + error + checksum
                start, err = 5, packet[4]
            if n != expected:
                batch.corrupt += 1
                if max_corrupt and batch.corrupt >= max_corrupt:
                    break
                continue
            batch.data[dxl_id] = bytes(packet[start:start + n])
            if err:
                batch.errors[dxl_id] = err
    finally:
        port.is_using = False  # the SDK leaves the port locked if a receive is abandoned
    return batch


class P1BulkRead(GroupBulkRead):
    """GroupBulkRead for Protocol 1.0 that sends the packet 4.1.0 fails to send, and receives tolerantly."""

    def txPacket(self) -> int:
        if not self.data_dict:
            return COMM_NOT_AVAILABLE
        if self.is_param_changed or not self.param:
            self.makeParam()
        return int(self.ph.bulkReadTx(self.port, self.param, len(self.data_dict) * 3))

    def receive(self) -> StatusBatch:
        lengths = {dxl_id: entry[2] for dxl_id, entry in self.data_dict.items()}
        return receive_statuses(self.ph, self.port, lengths)


class P2SyncRead(GroupSyncRead):
    """GroupSyncRead whose receive keeps the devices that answered when another one did not."""

    def receive(self) -> StatusBatch:
        return receive_statuses(self.ph, self.port, {dxl_id: self.data_length for dxl_id in self.data_dict})


def read_one(ph: Any, port: PortHandler, dxl_id: int, address: int, length: int, timeout_ms: float) -> StatusBatch:
    """A single READ with our own (short) timeout: used to find out which device went silent.
    A garbled answer ends the wait at once (batch.corrupt == 1): the device is alive."""
    if ph.readTx(port, dxl_id, address, length) != COMM_SUCCESS:
        port.is_using = False
        return StatusBatch(timed_out=True)
    port.setPacketTimeoutMillis(timeout_ms)
    return receive_statuses(ph, port, {dxl_id: length}, max_corrupt=1)
