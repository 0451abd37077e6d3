"""A raw camera image (sensor_msgs/Image) as the camera panel takes it: a JPEG CompressedImage (Pillow).

The panel and the browser show JPEG or PNG; a ROS 2 robot often publishes raw images (a camera driver's
``image_raw``). Encodings a camera gives in 8 bits per channel are taken; others (16-bit depth, Bayer) are refused
with the encoding named, never guessed.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from PIL import Image

from schemas import codec

JPEG_QUALITY = 80
# ROS 2 image encoding -> (channels, Pillow mode of the array, channel order to RGB)
_ENCODINGS: dict[str, tuple[int, str, tuple[int, ...] | None]] = {
    "mono8": (1, "L", None), "8uc1": (1, "L", None),
    "rgb8": (3, "RGB", None), "bgr8": (3, "RGB", (2, 1, 0)), "8uc3": (3, "RGB", (2, 1, 0)),
    "rgba8": (4, "RGB", (0, 1, 2)), "bgra8": (4, "RGB", (2, 1, 0)),
}


class ImageEncodingError(ValueError):
    """An image whose encoding or size the panel cannot show."""


def jpeg_of(image: Any) -> Any:
    """The CompressedImage (JPEG) of a decoded sensor_msgs/Image, with its header."""
    encoding = str(image.encoding).lower()
    if encoding not in _ENCODINGS:
        raise ImageEncodingError(f"image encoding {image.encoding!r} is not one the camera panel shows "
                                 f"({', '.join(sorted(_ENCODINGS))})")
    channels, mode, order = _ENCODINGS[encoding]
    height, width, step = int(image.height), int(image.width), int(image.step)
    data = np.asarray(image.data, dtype=np.uint8)
    if step < width * channels or data.size < step * height or not width or not height:
        raise ImageEncodingError(f"a {width}x{height} {encoding} image needs {width * channels * height} bytes "
                                 f"in rows of {step}, it has {data.size}")
    pixels = data[:step * height].reshape(height, step)[:, :width * channels].reshape(height, width, channels)
    if order is not None:
        pixels = pixels[:, :, list(order)]
    out = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(pixels.squeeze(axis=2) if channels == 1 else pixels), mode).save(
        out, format="JPEG", quality=JPEG_QUALITY)
    return codec.make("sensor_msgs/msg/CompressedImage", header=image.header, format="jpeg",
                      data=np.frombuffer(out.getvalue(), dtype=np.uint8))


# (type on the bus, panel's type) -> what makes one of the other
CONVERTERS = {("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage"): jpeg_of}
