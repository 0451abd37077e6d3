"""Test helper: what a screenshot shows, for views drawn with WebGL that a page script cannot read back."""

from __future__ import annotations

from collections.abc import Callable
from io import BytesIO
from typing import Any

from tests.waiting import wait_for


def picture(png: bytes) -> Any:
    """A PNG as an RGB PIL image."""
    from PIL import Image

    return Image.open(BytesIO(png)).convert("RGB")


def coloured_pixels(picture: Any) -> int:
    """Bright saturated pixels: rerun's plot lines and legend marks (its grey interface alone has ~300)."""
    from PIL import ImageChops

    hsv = picture.convert("HSV")
    saturation, value = hsv.getchannel("S"), hsv.getchannel("V")
    return sum(ImageChops.multiply(saturation.point(lambda v: 255 if v > 100 else 0),
                                   value.point(lambda v: 255 if v > 80 else 0)).histogram()[255:])


def changed_pixels(before: Any, after: Any) -> int:
    """Pixels that differ clearly between two pictures (all of them when the sizes differ)."""
    from PIL import ImageChops

    if before.size != after.size:
        return int(before.width * before.height)
    diff = ImageChops.difference(before, after).convert("L")
    return sum(diff.point(lambda v: 255 if v > 30 else 0).histogram()[255:])


def wait_for_moving_plot(shoot: Callable[[], Any], timeout: float) -> None:
    """Waits until rerun's viewer (pictured by ``shoot``) draws plot lines, then until they move with new data."""
    before = wait_for(lambda: (p := shoot(), coloured_pixels(p) > 2000)[1] and p, timeout, 1.0,
                      "plot lines drawn in the rerun viewer")
    wait_for(lambda: changed_pixels(before, shoot()) > 200, 30.0, 1.0, "the plots following new data")


def drawn_share(picture: Any) -> float:
    """Share of the pixels that differ clearly from the picture's most common colour (its background): 0 for a
    panel that draws nothing, a few per cent for a line of text, more for a field, a graph or a 3D view."""
    import numpy as np

    pixels = np.asarray(picture, dtype=np.int16).reshape(-1, 3)
    if len(pixels) == 0:
        return 0.0
    colours, counts = np.unique(pixels, axis=0, return_counts=True)
    background = colours[int(np.argmax(counts))]
    differ = int(np.count_nonzero(np.abs(pixels - background).sum(axis=1) > 60))
    return differ / len(pixels)
