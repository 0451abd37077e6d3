"""The speaking thread: espeak-ng runs here, one sentence at a time, so the node's loop never waits on audio."""

from __future__ import annotations

import queue
import threading
import time
import wave
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from robot_nodes.speaker.espeak import Espeak, SpeechError, SpeechJob, wav_duration
from robot_nodes.speaker.sentence_queue import Utterance


@dataclass(frozen=True, slots=True)
class SpeechResult:
    """What became of one sentence; ``error`` is '' when it was spoken."""

    utterance: Utterance
    job: SpeechJob
    wav_path: Path | None = None
    duration_s: float = 0.0
    error: str = ""


class SpeechWorker:
    """Speaks the jobs it is given in order and reports each result through ``on_done`` (from its own thread).

    With ``pace`` a WAV-only sentence keeps the worker busy for its audio length, as a loudspeaker would, so the
    queue behaves in the simulation as it does on the robot.
    """

    def __init__(self, on_done: Callable[[SpeechResult], None]) -> None:
        self._on_done = on_done
        self._jobs: queue.SimpleQueue[tuple[Utterance, SpeechJob, bool] | None] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._espeak = Espeak()
        self._thread = threading.Thread(target=self._work, name="speaker-espeak", daemon=True)
        self._thread.start()

    def submit(self, utterance: Utterance, job: SpeechJob, pace: bool) -> None:
        self._jobs.put((utterance, job, pace))

    def close(self, timeout: float = 3.0) -> None:
        """Ends the sentence being spoken and the thread."""
        self._stop.set()
        self._espeak.cancel()
        self._jobs.put(None)
        self._thread.join(timeout)

    def _work(self) -> None:
        while not self._stop.is_set():
            item = self._jobs.get()
            if item is None:
                return
            utterance, job, pace = item
            started = time.monotonic()
            try:
                path = self._espeak.say(job)
                duration = wav_duration(path) if path is not None else time.monotonic() - started
                if pace and path is not None:
                    self._stop.wait(max(0.0, duration - (time.monotonic() - started)))
                result = SpeechResult(utterance, job, path, duration)
            except (SpeechError, OSError, wave.Error, EOFError) as exc:
                result = SpeechResult(utterance, job, error=str(exc))
            if self._stop.is_set():
                return
            self._on_done(result)
