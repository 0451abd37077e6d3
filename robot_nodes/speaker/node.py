"""The speaker node (thesis 5.1.4): sentences from ``speak`` are said one at a time, the most important first."""

from __future__ import annotations

import re
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robot_nodes.runtime import Node, param
from robot_nodes.speaker.espeak import SpeechJob, espeak_available, last_sequence, prune_wavs, resolve_output, wav_name
from robot_nodes.speaker.sentence_queue import HIGH, LOW, MID, PRIORITY_NAMES, SpeechQueue, Utterance
from robot_nodes.speaker.worker import SpeechResult, SpeechWorker
from schemas.messages import Speak

# a folder per robot: the speakers of a simulated team share a machine, and two of them numbering their files in one
# folder took the same name at once ("could not say 'positioning'" for robots of one process at READY)
DEFAULT_FOLDER = "~/.cache/pitchside/speech/{robot}"
_CONTROL = re.compile(r"[\x00-\x1f\x7f]+")


@dataclass
class SpeakerParams:
    enabled: bool = param(True, doc="speak at all; while off, arriving sentences are dropped")
    output: str = param("auto", choices=["auto", "device", "wav"],
                        doc="device: the loudspeaker; wav: one file per sentence; auto: wav when ALSA has no card")
    folder: str = param(DEFAULT_FOLDER, doc="where wav output writes its files (~ is the home folder, {robot} the "
                                            "robot's id)")
    voice: str = param("en", doc="espeak-ng voice (see espeak-ng --voices)")
    rate: int = param(175, range=(80, 450), doc="words per minute")
    volume: int = param(100, range=(0, 200), doc="espeak-ng amplitude (100 is normal)")
    max_queue: int = param(10, range=(1, 1000), doc="sentences that may wait; when full the oldest least important go")
    drop_duplicates: bool = param(True, doc="drop a sentence when the same one already waits at its priority")
    pace_wav: bool = param(True, doc="wav output stays busy for the sentence's length, as a loudspeaker would")
    keep_files: int = param(500, range=(0, 1_000_000), doc="wav files kept in the folder, oldest deleted (0: all)")
    max_chars: int = param(500, range=(1, 10_000), doc="longer sentences are cut to this many characters")
    timeout_s: float = param(60.0, range=(1.0, 600.0), doc="espeak-ng is stopped after this long for one sentence")
    espeak_path: str = param("/usr/bin/espeak-ng", doc="the espeak-ng executable (a bare name is looked up in PATH)")


class SpeakerNode(Node):
    """Says the sentences of ``speak`` with espeak-ng: high before mid before low priority, in arrival order within."""

    name = "speaker"
    Params = SpeakerParams

    def setup(self) -> None:
        p = self.params
        self.queue = SpeechQueue(p.max_queue, p.drop_duplicates)
        self.current: Utterance | None = None
        self.spoken = 0
        self.dropped = 0
        self.last_file = ""
        self.sequence = last_sequence(self.folder)
        self._espeak_problem_reported = ""
        self.worker = SpeechWorker(lambda result: self.loop.call_soon(self._on_spoken, result))
        self.subscribe("speak", self.on_speak)
        self._update_diagnostics()

    # -- sentences in -----------------------------------------------------------------------------------
    def on_speak(self, msg: Speak) -> None:
        text = _CONTROL.sub(" ", msg.text).strip()[: self.params.max_chars]
        if not text:
            return
        if msg.priority not in PRIORITY_NAMES:
            self.record_error(f"speak: priority {msg.priority} is none of LOW_PRIORITY=0, MID_PRIORITY=1, "
                              f"HIGH_PRIORITY=2; sentence {text[:40]!r} dropped")
            self.dropped += 1
        elif not self.params.enabled or not self._espeak_ok():
            self.dropped += 1
        else:
            offer = self.queue.offer(text, int(msg.priority))
            if not offer.queued:
                self.dropped += 1
                self.log.info("not queued (%s): %r", offer.reason, text)
            if offer.dropped is not None:
                self.dropped += 1
                self.log.info("queue full: dropped %r", offer.dropped.text)
        self._speak_next()
        self._update_diagnostics()

    # -- speaking ---------------------------------------------------------------------------------------
    @property
    def folder(self) -> Path:
        return Path(self.params.folder.replace("{robot}", self.robot_id)).expanduser()

    @property
    def output(self) -> str:
        return resolve_output(self.params.output)

    @property
    def espeak_path(self) -> str:
        path = self.params.espeak_path
        return path if "/" in path else (shutil.which(path) or path)

    def _espeak_ok(self) -> bool:
        """Reports a missing espeak-ng once (per path), not once per sentence."""
        problem = espeak_available(self.espeak_path)
        if problem and problem != self._espeak_problem_reported:
            self._espeak_problem_reported = problem
            self.record_error(f"{problem}; sentences are dropped")
        elif not problem:
            self._espeak_problem_reported = ""
        return not problem

    def _speak_next(self) -> None:
        if self.current is not None or not self.params.enabled:
            return
        if not self._espeak_ok():
            self.dropped += len(self.queue.clear())
            return
        utterance = self.queue.pop()
        if utterance is None:
            return
        p = self.params
        output = self.output
        wav_path = None
        if output == "wav":
            self.sequence += 1
            wav_path = self.folder / wav_name(self.sequence, utterance.priority_name, utterance.text)
        job = SpeechJob(utterance.text, self.espeak_path, p.voice, p.rate, p.volume, output, wav_path, p.timeout_s)
        self.current = utterance
        self.worker.submit(utterance, job, pace=p.pace_wav)

    def _on_spoken(self, result: SpeechResult) -> None:
        self.current = None
        if result.error:
            self.record_error(f"could not say {result.utterance.text[:40]!r}: {result.error}")
        else:
            self.spoken += 1
            if result.wav_path is not None:
                self.last_file = result.wav_path.name
                prune_wavs(result.wav_path.parent, self.params.keep_files)
        self._speak_next()
        self._update_diagnostics()

    # -- parameters, diagnostics, shutdown ---------------------------------------------------------------
    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        if "max_queue" in changed:
            self.dropped += len(self.queue.resize(self.params.max_queue))
        if "drop_duplicates" in changed:
            self.queue.drop_duplicates = self.params.drop_duplicates
        if "enabled" in changed and not self.params.enabled:
            self.dropped += len(self.queue.clear())
        if "folder" in changed:
            self.sequence = max(self.sequence, last_sequence(self.folder))
        self._speak_next()
        self._update_diagnostics()

    def _update_diagnostics(self) -> None:
        self.set_diagnostic("queue_high", self.queue.waiting(HIGH))
        self.set_diagnostic("queue_mid", self.queue.waiting(MID))
        self.set_diagnostic("queue_low", self.queue.waiting(LOW))
        self.set_diagnostic("spoken", self.spoken)
        self.set_diagnostic("dropped", self.dropped)
        self.set_diagnostic("speaking", self.current.text if self.current else "")
        self.set_diagnostic("output", self.output)
        self.set_diagnostic("last_file", self.last_file)

    def on_shutdown(self) -> None:
        self.worker.close()
