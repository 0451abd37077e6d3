"""The speaker node with real espeak-ng writing real WAV files, over a real Zenoh router: priority order, live
parameters, a missing espeak-ng, bad input; plus the sentence queue on its own."""

from __future__ import annotations

import array
import signal
import subprocess
import sys
import wave
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import schemas
from robot_nodes.runtime import BusConfig, Node, ParameterClient
from robot_nodes.speaker import HIGH, LOW, MID, SpeakerNode, SpeechQueue, has_sound_device, resolve_output, slug
from robot_nodes.speaker.espeak import WAV_NAME, last_sequence, prune_wavs, wav_name
from tests.waiting import wait_for

pytestmark = pytest.mark.realtime

ESPEAK = "/usr/bin/espeak-ng"
needs_espeak = pytest.mark.skipif(not Path(ESPEAK).exists(), reason="espeak-ng is missing (apt install espeak-ng)")
KICKOFF = ("The referee has whistled the start of the second half, our striker walks toward the ball while the "
           "goalie watches the penalty area and the defenders hold their line.")


class Coach(Node):
    """Stands where the HCM and behaviour would: sends sentences, reads the speaker's diagnostics."""

    name = "coach"

    def setup(self) -> None:
        self.speak_pub = self.publisher("speak")
        self.diagnostics: dict[str, str] = {}
        self.diag_message = ""
        self.subscribe("diagnostics", self._on_diagnostics)

    def _on_diagnostics(self, msg: Any) -> None:
        for status in msg.status:
            if status.name.endswith("/speaker"):
                self.diagnostics = {kv.key: kv.value for kv in status.values}
                self.diag_message = status.message

    def say(self, text: str, priority: int) -> None:
        self.speak_pub.publish(schemas.make("humanoid_league_msgs/msg/Speak", text=text, priority=priority))


@pytest.fixture
def coach(bus: BusConfig) -> Iterator[Coach]:
    node = Coach(bus=bus)
    node.start()
    yield node
    node.shutdown()


def start_speaker(bus: BusConfig, coach: Coach, **overrides: Any) -> SpeakerNode:
    node = SpeakerNode(bus=bus, overrides={"output": "wav", **overrides})
    node.start()
    wait_for(lambda: coach.speak_pub.has_subscribers, 10.0, what="speaker subscribed to speak")
    return node


def wavs(folder: Path) -> list[Path]:
    """Utterance files in the order of their sequence numbers."""
    if not folder.is_dir():
        return []
    return sorted((f for f in folder.iterdir() if WAV_NAME.match(f.name)), key=lambda f: int(f.name.split("-")[0]))


def wait_wavs(folder: Path, count: int, timeout: float, what: str) -> list[Path]:
    """Waits until the folder holds exactly ``count`` utterance files."""
    return wait_for(lambda: wavs(folder) if len(wavs(folder)) == count else [], timeout, what=what)


def duration(path: Path) -> float:
    """Seconds of audio; fails the test unless the file is a valid, non-empty WAV."""
    with wave.open(str(path), "rb") as w:
        assert w.getnchannels() == 1 and w.getsampwidth() == 2 and w.getframerate() > 8000
        assert w.getnframes() > 0
        return w.getnframes() / w.getframerate()


def peak(path: Path) -> int:
    with wave.open(str(path), "rb") as w:
        samples = array.array("h", w.readframes(w.getnframes()))
    return max(abs(s) for s in samples)


# -- the sentence queue alone ---------------------------------------------------------------------------------
def test_queue_speaks_highest_priority_first_and_fifo_within() -> None:
    q = SpeechQueue(max_waiting=10)
    for text, prio in [("low one", LOW), ("mid one", MID), ("high one", HIGH), ("low two", LOW), ("high two", HIGH)]:
        assert q.offer(text, prio).queued
    order = [u.text for u in iter(q.pop, None)]
    assert order == ["high one", "high two", "mid one", "low one", "low two"]


def test_full_queue_drops_oldest_least_important_and_refuses_less_important() -> None:
    q = SpeechQueue(max_waiting=3)
    q.offer("low a", LOW)
    q.offer("low b", LOW)
    q.offer("mid a", MID)
    offer = q.offer("high a", HIGH)
    assert offer.queued and offer.dropped is not None and offer.dropped.text == "low a"
    q.offer("high b", HIGH)  # drops low b
    refused = q.offer("low c", LOW)
    assert not refused.queued and "full" in refused.reason
    assert [u.text for u in iter(q.pop, None)] == ["high a", "high b", "mid a"]


def test_duplicates_and_bad_priority() -> None:
    q = SpeechQueue(max_waiting=5, drop_duplicates=True)
    assert q.offer("ball found", MID).queued
    assert not q.offer("ball found", MID).queued
    assert q.offer("ball found", HIGH).queued  # another priority is another request
    q.drop_duplicates = False
    assert q.offer("ball found", MID).queued
    with pytest.raises(ValueError, match="priority 7"):
        q.offer("x", 7)
    assert len(q) == 3
    assert [u.text for u in q.resize(1)] == ["ball found", "ball found"]
    assert q.waiting(HIGH) == 1


def test_names_and_sound_device_detection(tmp_path: Path) -> None:
    assert slug("Ball found! Über-Tor 3:1") == "ball-found-uber-tor-3-1"
    assert wav_name(42, "high", "Falling!") == "000042-high-falling.wav"
    assert WAV_NAME.match(wav_name(1234567, "low", "")) is not None
    cards = tmp_path / "cards"
    assert not has_sound_device(cards) and resolve_output("auto", cards) == "wav"
    cards.write_text("--- no soundcards ---\n")
    assert resolve_output("auto", cards) == "wav"
    cards.write_text(" 0 [PCH            ]: HDA-Intel - HDA Intel PCH\n")
    assert resolve_output("auto", cards) == "device"
    assert resolve_output("wav", cards) == "wav"
    for seq in (3, 9, 5):
        (tmp_path / wav_name(seq, "mid", "x")).write_bytes(b"")
    assert last_sequence(tmp_path) == 9
    assert prune_wavs(tmp_path, 1) == 2 and [f.name for f in wavs(tmp_path)] == ["000009-mid-x.wav"]


# -- the node with real espeak-ng -----------------------------------------------------------------------------
@needs_espeak
@pytest.mark.timeout(120)
def test_waiting_sentences_come_out_high_mid_low(bus: BusConfig, coach: Coach, tmp_path: Path) -> None:
    folder = tmp_path / "speech"
    speaker = start_speaker(bus, coach, folder=str(folder))
    try:
        coach.say(KICKOFF, LOW)
        # the kickoff sentence's file exists: it is now being "played" for its ~9 s of audio
        first = wait_for(lambda: wavs(folder), 30.0, what="the first sentence's WAV")[0]
        coach.say("low priority sentence", LOW)
        coach.say("high priority sentence", HIGH)
        coach.say("mid priority sentence", MID)
        wait_for(lambda: len(speaker.queue) == 3, 10.0, what="three sentences waiting")
        assert speaker.current is not None and speaker.current.text == KICKOFF, "the kickoff ended too early"
        files = wait_wavs(folder, 4, 60.0, "four WAV files")
        assert files[0] == first and first.name.startswith("000001-low-the-referee")
        assert [f.name.split("-", 1)[1] for f in files[1:]] == [
            "high-high-priority-sentence.wav", "mid-mid-priority-sentence.wav", "low-low-priority-sentence.wav"]
        numbers = [int(f.name.split("-")[0]) for f in files]
        assert numbers == sorted(numbers) and len(set(numbers)) == 4
        assert duration(first) > 5.0
        assert all(duration(f) > 0.1 for f in files)
        wait_for(lambda: coach.diagnostics.get("spoken") == "4", 15.0, what="diagnostics counting four spoken")
        diag = coach.diagnostics
        assert diag["queue_high"] == diag["queue_mid"] == diag["queue_low"] == "0"
        assert diag["output"] == "wav" and diag["last_file"] == files[-1].name
    finally:
        speaker.shutdown()


@needs_espeak
@pytest.mark.timeout(90)
def test_rate_and_volume_change_live(bus: BusConfig, coach: Coach, tmp_path: Path) -> None:
    folder = tmp_path / "speech"
    speaker = start_speaker(bus, coach, folder=str(folder), rate=80, pace_wav=False)
    sentence = "Ball is out, throw in for the red team"
    try:
        params = ParameterClient(coach.session, "robot1", timeout=10)
        coach.say(sentence, MID)
        slow = wait_for(lambda: wavs(folder), 30.0, what="the slow sentence")[0]
        params.set("speaker", {"rate": 450, "volume": 20})
        assert params.get("speaker", "rate") == 450
        coach.say(sentence, MID)
        files = wait_wavs(folder, 2, 30.0, "the fast sentence")
        fast = files[1]
        assert duration(fast) < 0.5 * duration(slow), (duration(fast), duration(slow))
        assert peak(fast) < 0.5 * peak(slow), (peak(fast), peak(slow))
        with pytest.raises(ValueError, match="out of range"):
            params.set("speaker", {"rate": 1000})
        assert speaker.params.rate == 450
    finally:
        speaker.shutdown()


@pytest.mark.timeout(90)
def test_missing_espeak_is_reported_once_and_node_survives(bus: BusConfig, coach: Coach, tmp_path: Path) -> None:
    folder = tmp_path / "speech"
    speaker = start_speaker(bus, coach, folder=str(folder), espeak_path=str(tmp_path / "no" / "espeak-ng"))
    try:
        for i in range(3):
            coach.say(f"ball found {i}", HIGH)
        wait_for(lambda: coach.diagnostics.get("dropped") == "3", 15.0, what="three dropped sentences")
        assert "espeak-ng not found" in coach.diag_message and "espeak_path" in coach.diag_message
        assert coach.diagnostics["errors"] == "1", "a missing espeak-ng is reported once, not per sentence"
        coach.say("strange priority", 7)
        wait_for(lambda: "priority 7" in coach.diag_message, 15.0, what="the bad priority reported")
        if not Path(ESPEAK).exists():
            return
        ParameterClient(coach.session, "robot1", timeout=10).set("speaker", {"espeak_path": "espeak-ng"})
        coach.say("back in the game", LOW)
        spoken = wait_for(lambda: wavs(folder), 30.0, what="a sentence once espeak-ng is found")
        assert spoken[0].name.endswith("-low-back-in-the-game.wav") and duration(spoken[0]) > 0.1
    finally:
        speaker.shutdown()


@needs_espeak
@pytest.mark.timeout(90)
def test_unknown_voice_is_an_error_not_a_crash(bus: BusConfig, coach: Coach, tmp_path: Path) -> None:
    folder = tmp_path / "speech"
    speaker = start_speaker(bus, coach, folder=str(folder), voice="klingon-xx", pace_wav=False)
    try:
        coach.say("penalized", HIGH)
        wait_for(lambda: "voice" in coach.diag_message, 15.0, what="espeak-ng's voice error in diagnostics")
        assert wavs(folder) == [] and not list(folder.glob("*.part"))
        speaker.parameters.set({"voice": "en"})
        coach.say("unpenalized", HIGH)
        assert wait_for(lambda: wavs(folder), 30.0, what="speech with a good voice")[0].name.endswith("unpenalized.wav")
    finally:
        speaker.shutdown()


@needs_espeak
@pytest.mark.timeout(90)
def test_robots_of_one_machine_say_their_sentences_into_folders_of_their_own(bus: BusConfig, tmp_path: Path) -> None:
    """A simulated team's speakers share a machine (the default folder names the robot): each numbers its files in
    its own folder, so two sentences said at the same moment both come out."""
    robots = ("home1", "home2", "home3")
    template = str(tmp_path / "speech" / "{robot}")
    coaches = [Coach(bus=bus, robot_id=robot) for robot in robots]
    speakers = [SpeakerNode(bus=bus, robot_id=robot, overrides={"output": "wav", "folder": template,
                                                                "pace_wav": False}) for robot in robots]
    for node in (*coaches, *speakers):
        node.start()
    try:
        wait_for(lambda: all(c.speak_pub.has_subscribers for c in coaches), 10.0, what="speakers subscribed")
        for coach in coaches:
            coach.say("positioning", LOW)
        for robot, speaker in zip(robots, speakers, strict=True):
            assert speaker.folder == tmp_path / "speech" / robot
            spoken = wait_for(lambda s=speaker: wavs(s.folder), 30.0, what=f"{robot}'s sentence")
            assert [f.name for f in spoken] == ["000001-low-positioning.wav"]
            assert wait_for(lambda s=speaker: s.spoken == 1, 10.0, what=f"{robot}'s speaker done")
        assert all(coach.diag_message in ("", "OK") for coach in coaches), [c.diag_message for c in coaches]
    finally:
        for node in (*speakers, *coaches):
            node.shutdown()


@needs_espeak
@pytest.mark.timeout(90)
def test_speaker_process(router_endpoint: str, coach: Coach, tmp_path: Path) -> None:
    folder = tmp_path / "speech"
    (folder).mkdir()
    (folder / wav_name(41, "low", "from an earlier run")).write_bytes(b"")
    proc = subprocess.Popen([sys.executable, "-m", "robot_nodes.speaker", "--connect", router_endpoint,
                             "--set", "output=wav", "--set", f"folder={folder}"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        wait_for(lambda: coach.speak_pub.has_subscribers, 30.0, what="the speaker process subscribed")
        coach.say("Kick off", HIGH)
        files = wait_for(lambda: [f for f in wavs(folder) if f.stat().st_size], 30.0, what="the process's WAV")
        assert files[0].name == "000042-high-kick-off.wav", "numbering goes on from the files already there"
        assert duration(files[0]) > 0.1
    finally:
        proc.send_signal(signal.SIGTERM)
        output = proc.communicate(timeout=20)[0].decode(errors="replace")
    assert proc.returncode == 0, output



@needs_espeak
@pytest.mark.skipif(has_sound_device(), reason="this machine has a sound card: device output would really play")
@pytest.mark.timeout(90)
def test_device_output_without_a_sound_card_is_an_error(bus: BusConfig, coach: Coach, tmp_path: Path) -> None:
    speaker = start_speaker(bus, coach, output="device", folder=str(tmp_path))
    try:
        coach.say("corner kick", MID)
        wait_for(lambda: "could not say 'corner kick'" in coach.diag_message, 20.0, what="the ALSA error reported")
        assert coach.diagnostics["output"] == "device" and wavs(tmp_path) == []
        speaker.parameters.set({"output": "auto"})  # what a simulation should use
        coach.say("corner kick", MID)
        assert wait_wavs(tmp_path, 1, 30.0, "auto output falling back to WAV")[0].name.endswith("-mid-corner-kick.wav")
    finally:
        speaker.shutdown()


@needs_espeak
@pytest.mark.timeout(90)
def test_full_queue_drops_oldest_low_and_duplicates(bus: BusConfig, coach: Coach, tmp_path: Path) -> None:
    speaker = start_speaker(bus, coach, folder=str(tmp_path), max_queue=2, rate=300)
    try:
        coach.say(KICKOFF, HIGH)
        wait_wavs(tmp_path, 1, 30.0, "the kickoff sentence being played")
        for text in ("one", "one", "two", "three"):
            coach.say(text, LOW)
        wait_for(lambda: speaker.dropped == 2, 10.0, what="a duplicate and the oldest low sentence dropped")
        assert speaker.current is not None and speaker.current.text == KICKOFF, "the kickoff ended too early"
        files = wait_wavs(tmp_path, 3, 60.0, "the two kept sentences")
        assert [f.name.split("-", 1)[1] for f in files[1:]] == ["low-two.wav", "low-three.wav"]
        wait_for(lambda: coach.diagnostics.get("dropped") == "2", 15.0, what="drops in diagnostics")
    finally:
        speaker.shutdown()
