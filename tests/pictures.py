"""Test helper: what a screenshot shows, for views drawn with WebGL that a page script cannot read back."""

from __future__ import annotations

from io import BytesIO
from typing import Any


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
