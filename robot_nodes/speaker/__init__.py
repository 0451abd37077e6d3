"""pitchside speaker node: priority-queued sentences said by espeak-ng, on the loudspeaker or into WAV files."""

from robot_nodes.speaker.espeak import SpeechError, SpeechJob, has_sound_device, resolve_output, slug, wav_name
from robot_nodes.speaker.node import SpeakerNode, SpeakerParams
from robot_nodes.speaker.sentence_queue import HIGH, LOW, MID, Offer, SpeechQueue, Utterance

__all__ = [
    "HIGH",
    "LOW",
    "MID",
    "Offer",
    "SpeakerNode",
    "SpeakerParams",
    "SpeechError",
    "SpeechJob",
    "SpeechQueue",
    "Utterance",
    "has_sound_device",
    "resolve_output",
    "slug",
    "wav_name",
]
