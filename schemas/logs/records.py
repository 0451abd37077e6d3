"""Low-level MCAP record access: reading a chunk at an offset, and rebuilding the index of a
file whose summary is missing (recording cut off, crash) by one streaming pass."""

from __future__ import annotations

import io
import struct
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import IO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    Footer,
    McapRecord,
    Message,
    MessageIndex,
    Metadata,
    Schema,
    Statistics,
)
from mcap.stream_reader import breakup_chunk, get_chunk_data_stream
from mcap.summary import Summary

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<HIQ")  # channel id, sequence, log time

# Records a recovery pass needs; everything else (attachments, old indexes) is skipped.
_READERS: dict[int, Callable[[ReadDataStream, int], McapRecord]] = {
    Opcode.SCHEMA: lambda s, n: Schema.read(s),
    Opcode.CHANNEL: lambda s, n: Channel.read(s),
    Opcode.MESSAGE: lambda s, n: Message.read(s, n),
    Opcode.CHUNK: lambda s, n: Chunk.read(s),
    Opcode.MESSAGE_INDEX: lambda s, n: MessageIndex.read(s),
    Opcode.METADATA: lambda s, n: Metadata.read(s),
    Opcode.FOOTER: lambda s, n: Footer.read(s),
}


def read_record_at(stream: IO[bytes], offset: int) -> McapRecord:
    """The record starting at ``offset`` (an index entry); ValueError if it is cut short or unknown."""
    stream.seek(offset)
    head = stream.read(_RECORD_HEAD.size)
    if len(head) < _RECORD_HEAD.size:
        raise ValueError(f"record at byte {offset} is cut short")
    opcode, length = _RECORD_HEAD.unpack(head)
    body = stream.read(length)
    if len(body) < length or opcode not in _READERS:
        raise ValueError(f"record at byte {offset} (opcode {opcode:#x}) is cut short or unknown")
    return _READERS[opcode](ReadDataStream(io.BytesIO(body)), length)


def chunk_messages(stream: IO[bytes], index: ChunkIndex, validate_crc: bool = False) -> list[Message]:
    """The messages of the chunk an index entry points at, in file order."""
    chunk = read_record_at(stream, index.chunk_start_offset)
    if not isinstance(chunk, Chunk):
        raise ValueError(f"no chunk at byte {index.chunk_start_offset}")
    return [r for r in breakup_chunk(chunk, validate_crc=validate_crc) if isinstance(r, Message)]


@dataclass
class ChunkContents:
    """What a recovery pass needs from a chunk, found without building every message."""

    definitions: list[McapRecord]  # schema and channel records
    counts: dict[int, int]  # messages per channel
    start: int
    end: int


def survey_chunk(chunk: Chunk) -> ChunkContents:
    """Decompresses (CRC-checked) and walks the records of a chunk; ValueError if it is damaged."""
    stream, length = get_chunk_data_stream(chunk, validate_crc=True)
    data = memoryview(stream.read(length)) if length else memoryview(b"")
    found = ChunkContents([], {}, 0, 0)
    first = True
    position = 0
    while position < length:
        if position + _RECORD_HEAD.size > length:
            raise ValueError("chunk ends inside a record header")
        opcode, size = _RECORD_HEAD.unpack_from(data, position)
        body = position + _RECORD_HEAD.size
        if body + size > length:
            raise ValueError("chunk ends inside a record")
        if opcode == Opcode.MESSAGE:
            if size < _MESSAGE_HEAD.size:
                raise ValueError("message record too short")
            channel_id, _, log_time = _MESSAGE_HEAD.unpack_from(data, body)
            found.counts[channel_id] = found.counts.get(channel_id, 0) + 1
            found.start = log_time if first else min(found.start, log_time)
            found.end = log_time if first else max(found.end, log_time)
            first = False
        elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL):
            found.definitions.append(_READERS[opcode](ReadDataStream(io.BytesIO(data[body:body + size])), size))
        position = body + size
    return found


@dataclass
class Recovery:
    """What one streaming pass over an unindexed file found."""

    summary: Summary
    metadata: list[Metadata] = field(default_factory=list)
    loose_messages: int = 0  # messages outside chunks (an unchunked file): read by streaming
    problem: str = ""  # why the pass stopped early ("" if it reached the footer)
    complete_bytes: int = 0


def recover_index(stream: IO[bytes], size: int, on_progress: Callable[[float], None] | None = None) -> Recovery:
    """Walks the records from the start, building the summary the file lacks.

    Stops at the first record that is cut short or does not parse: everything before it is
    kept (every complete chunk), the rest is reported in ``problem``.
    """
    summary = Summary()
    stats = Statistics(attachment_count=0, channel_count=0, channel_message_counts={}, chunk_count=0,
                       message_count=0, message_end_time=0, message_start_time=0, metadata_count=0,
                       schema_count=0)
    summary.statistics = stats
    found = Recovery(summary)
    last_chunk: ChunkIndex | None = None
    reported = -1.0

    def note(record: McapRecord) -> None:
        if isinstance(record, Schema):
            summary.schemas[record.id] = record
        elif isinstance(record, Channel):
            summary.channels[record.id] = record
        elif isinstance(record, Message):
            if stats.message_count == 0 or record.log_time < stats.message_start_time:
                stats.message_start_time = record.log_time
            stats.message_end_time = max(stats.message_end_time, record.log_time)
            stats.message_count += 1
            counts = stats.channel_message_counts
            counts[record.channel_id] = counts.get(record.channel_id, 0) + 1
            found.loose_messages += 1  # outside any chunk

    stream.seek(len(MAGIC))
    offset = len(MAGIC)
    while True:
        if on_progress is not None and size and offset / size - reported >= 0.01:
            reported = offset / size
            on_progress(min(reported, 1.0))
        head = stream.read(_RECORD_HEAD.size)
        if not head:
            found.problem = f"file ends at byte {offset} without a footer"
            break
        if len(head) < _RECORD_HEAD.size:
            found.problem = f"file is cut inside a record header at byte {offset}"
            break
        opcode, length = _RECORD_HEAD.unpack(head)
        if length > size - offset - _RECORD_HEAD.size:
            name = Opcode(opcode).name.lower() if opcode in Opcode._value2member_map_ else f"{opcode:#x}"
            found.problem = f"file is cut inside a {name} record at byte {offset} of {size}"
            break
        body = stream.read(length)
        try:
            record = _READERS[opcode](ReadDataStream(io.BytesIO(body)), length) if opcode in _READERS else None
            contents = survey_chunk(record) if isinstance(record, Chunk) else None
        except Exception as exc:  # a damaged record: keep what came before it
            found.problem = f"record at byte {offset} does not parse ({exc})"
            break
        if isinstance(record, Chunk) and contents is not None:
            last_chunk = ChunkIndex(
                message_start_time=contents.start, message_end_time=contents.end,
                chunk_start_offset=offset, chunk_length=_RECORD_HEAD.size + length, message_index_offsets={},
                message_index_length=0, compression=record.compression, compressed_size=len(record.data),
                uncompressed_size=record.uncompressed_size)
            for definition in contents.definitions:
                note(definition)
            if contents.counts:
                summary.chunk_indexes.append(last_chunk)
                stats.chunk_count += 1
                count = sum(contents.counts.values())
                if stats.message_count == 0 or contents.start < stats.message_start_time:
                    stats.message_start_time = contents.start
                stats.message_end_time = max(stats.message_end_time, contents.end)
                stats.message_count += count
                for channel_id, n in contents.counts.items():
                    stats.channel_message_counts[channel_id] = stats.channel_message_counts.get(channel_id, 0) + n
        elif isinstance(record, MessageIndex) and last_chunk is not None:
            last_chunk.message_index_offsets[record.channel_id] = offset
        elif isinstance(record, Metadata):
            found.metadata.append(record)
            stats.metadata_count += 1
        elif isinstance(record, Footer):
            break
        elif record is not None:
            note(record)
        offset += _RECORD_HEAD.size + length
        found.complete_bytes = offset
    stats.schema_count = len(summary.schemas)
    stats.channel_count = len(summary.channels)
    if on_progress is not None:
        on_progress(1.0)
    return found


def stream_messages(stream: IO[bytes], size: int) -> Iterator[Message]:
    """Every complete message in file order, chunked or not, until the file ends or breaks."""
    stream.seek(len(MAGIC))
    offset = len(MAGIC)
    while True:
        head = stream.read(_RECORD_HEAD.size)
        if len(head) < _RECORD_HEAD.size:
            return
        opcode, length = _RECORD_HEAD.unpack(head)
        if length > size - offset - _RECORD_HEAD.size or opcode == Opcode.FOOTER:
            return
        body = stream.read(length)
        offset += _RECORD_HEAD.size + length
        if opcode == Opcode.MESSAGE:
            yield Message.read(ReadDataStream(io.BytesIO(body)), length)
        elif opcode == Opcode.CHUNK:
            try:
                inner = breakup_chunk(Chunk.read(ReadDataStream(io.BytesIO(body))), validate_crc=True)
            except Exception:
                return
            for record in inner:
                if isinstance(record, Message):
                    yield record
