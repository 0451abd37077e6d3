"""Camera images for the link: JPEG decoded, downscaled and re-encoded small (Pillow), or passed through."""

from __future__ import annotations

import io

from PIL import Image


class ImageError(Exception):
    """The camera bytes are not an image Pillow can read."""


def shrink_jpeg(data: bytes, max_width: int, quality: int) -> bytes:
    """A JPEG at most ``max_width`` pixels wide; ``max_width`` 0 passes the bytes through.

    A JPEG already narrow enough is re-encoded only if that makes it smaller at ``quality``.
    """
    if max_width <= 0:
        return data
    try:
        with Image.open(io.BytesIO(data)) as img:
            width, height = img.size
            if width > max_width:
                target = (max_width, max(1, round(height * max_width / width)))
                img.draft("RGB", target)  # DCT scaling: decode at 1/2, 1/4, 1/8 size directly, much faster
                out = img.convert("RGB").resize(target, Image.Resampling.BILINEAR)
            else:
                out = img.convert("RGB")
            buf = io.BytesIO()
            out.save(buf, format="JPEG", quality=quality)
    except (OSError, ValueError, Image.DecompressionBombError) as exc:
        raise ImageError(f"camera image of {len(data)} bytes does not decode: {exc}") from exc
    small = buf.getvalue()
    return small if width > max_width or len(small) < len(data) else data
