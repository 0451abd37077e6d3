"""Saying one sentence with espeak-ng: on the sound device, or into a WAV file named so the spoken order shows."""

from __future__ import annotations

import os
import re
import subprocess
import threading
import unicodedata
import wave
from dataclasses import dataclass
from pathlib import Path

ASOUND_CARDS = Path("/proc/asound/cards")
WAV_NAME = re.compile(r"^(?P<seq>\d{6,})-(?P<priority>low|mid|high)-(?P<slug>[a-z0-9-]*)\.wav$")


class SpeechError(RuntimeError):
    """espeak-ng is missing or failed; the message says which and why."""


def has_sound_device(cards: Path = ASOUND_CARDS) -> bool:
    """True when ALSA lists a sound card (a simulation or a container usually has none)."""
    try:
        text = cards.read_text()
    except OSError:
        return False
    return bool(text.strip()) and "no soundcards" not in text


def resolve_output(output: str, cards: Path = ASOUND_CARDS) -> str:
    """'device' or 'wav' for the ``output`` parameter ('auto' asks ALSA)."""
    if output == "auto":
        return "device" if has_sound_device(cards) else "wav"
    if output not in ("device", "wav"):
        raise ValueError(f"output must be auto, device or wav, got {output!r}")
    return output


def espeak_available(path: str) -> str:
    """'' when the espeak-ng executable is usable, else why not."""
    p = Path(path)
    if not p.exists():
        return f"espeak-ng not found at {path} (apt install espeak-ng, or set the espeak_path parameter)"
    if not p.is_file() or not os.access(p, os.X_OK):
        return f"espeak-ng at {path} is not an executable file"
    return ""


def slug(text: str, length: int = 40) -> str:
    """A file-name-safe, lower-case digest of the sentence ('Ball found!' -> 'ball-found')."""
    ascii_text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode()
    words = re.sub(r"[^a-z0-9]+", "-", ascii_text.lower()).strip("-")
    return words[:length].rstrip("-")


def wav_name(sequence: int, priority_name: str, text: str) -> str:
    """``000042-high-ball-found.wav``: sorting the names sorts by the order of speaking."""
    return f"{sequence:06d}-{priority_name}-{slug(text)}.wav"


def last_sequence(folder: Path) -> int:
    """The highest sequence number already in the folder, so a restarted node keeps counting up."""
    if not folder.is_dir():
        return 0
    numbers = [int(m["seq"]) for f in folder.iterdir() if (m := WAV_NAME.match(f.name))]
    return max(numbers, default=0)


def prune_wavs(folder: Path, keep: int) -> int:
    """Deletes the oldest utterance files beyond ``keep`` (0 keeps all); returns how many went."""
    if keep <= 0:
        return 0
    files = sorted((int(m["seq"]), f) for f in folder.iterdir() if (m := WAV_NAME.match(f.name)))
    gone = 0
    for _, f in files[: max(0, len(files) - keep)]:
        try:
            f.unlink()
            gone += 1
        except OSError:
            pass
    return gone


def wav_duration(path: Path) -> float:
    with wave.open(str(path), "rb") as w:
        return w.getnframes() / float(w.getframerate())


@dataclass(frozen=True, slots=True)
class SpeechJob:
    """One sentence with the settings it is spoken with (a snapshot: live changes apply to the next sentence)."""

    text: str
    espeak_path: str
    voice: str
    rate: int
    volume: int
    output: str  # 'device' or 'wav', already resolved
    wav_path: Path | None = None
    timeout_s: float = 60.0

    def command(self, target: Path | None = None) -> list[str]:
        # the sentence goes in on stdin: no text can ever be read as an option
        cmd = [self.espeak_path, "-a", str(self.volume), "-v", self.voice, "-s", str(self.rate)]
        if target is not None:
            cmd += ["-w", str(target)]
        return [*cmd, "--stdin"]


class Espeak:
    """Runs espeak-ng for one job at a time; ``cancel`` ends the running one (node shutdown)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._process: subprocess.Popen[bytes] | None = None
        self._cancelled = threading.Event()

    def say(self, job: SpeechJob) -> Path | None:
        """Speaks (or writes) the sentence; returns the WAV path in wav mode. SpeechError on failure."""
        problem = espeak_available(job.espeak_path)
        if problem:
            raise SpeechError(problem)
        target = None
        if job.output == "wav":
            if job.wav_path is None:
                raise SpeechError("wav output needs a file path")
            job.wav_path.parent.mkdir(parents=True, exist_ok=True)
            # written under a temporary name and renamed: a watcher only ever sees complete files
            target = job.wav_path.with_name(job.wav_path.name + ".part")
        self._run(job, target)
        if target is None:
            return None
        assert job.wav_path is not None
        try:
            with wave.open(str(target), "rb") as w:
                if w.getnframes() == 0:
                    raise SpeechError(f"espeak-ng wrote no audio for {job.text!r} (voice {job.voice!r})")
        except (wave.Error, EOFError, OSError) as exc:
            target.unlink(missing_ok=True)
            raise SpeechError(f"espeak-ng wrote no valid WAV: {exc}") from exc
        target.replace(job.wav_path)
        return job.wav_path

    def _run(self, job: SpeechJob, target: Path | None) -> None:
        with self._lock:
            if self._cancelled.is_set():
                raise SpeechError("speaker is shutting down")
            try:
                process = subprocess.Popen(job.command(target), stdin=subprocess.PIPE,
                                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            except OSError as exc:
                raise SpeechError(f"cannot run espeak-ng at {job.espeak_path}: {exc}") from exc
            self._process = process
        try:
            _, err = process.communicate(job.text.encode(), timeout=job.timeout_s)
        except subprocess.TimeoutExpired as exc:
            process.kill()
            process.communicate()
            raise SpeechError(f"espeak-ng took longer than {job.timeout_s} s for {job.text[:40]!r}") from exc
        finally:
            with self._lock:
                self._process = None
        if self._cancelled.is_set():
            raise SpeechError("speaker is shutting down")
        message = err.decode(errors="replace").strip()
        # espeak-ng exits 1 on an unknown voice, but 0 when ALSA has no device: then only stderr tells
        if process.returncode != 0 or "error" in message.lower():
            last = message.splitlines()[-1][:300] if message else "no message"
            raise SpeechError(f"espeak-ng failed (exit code {process.returncode}): {last}")

    def cancel(self) -> None:
        self._cancelled.set()
        with self._lock:
            if self._process is not None and self._process.poll() is None:
                self._process.kill()
