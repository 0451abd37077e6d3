"""Test helper: what a screenshot shows, for views drawn with WebGL that a page script cannot read back, and whether
a layout preset fits the window (shared by the browser tests and `./run pictures`)."""

from __future__ import annotations

from collections.abc import Callable
from io import BytesIO
from typing import Any

from tests.waiting import wait_for

MIN_DRAWN = 0.004  # a panel body with less than this share of non-background pixels draws nothing


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


def layout_problems(page: Any, panels: list[str]) -> list[str]:
    """Page scrolling, panels outside the window or under the playback bar."""
    found: list[str] = page.evaluate("""(panels) => {
        const problems = [], doc = document.documentElement;
        if (doc.scrollHeight > innerHeight || doc.scrollWidth > innerWidth)
          problems.push(`the page scrolls: ${doc.scrollWidth}x${doc.scrollHeight} in ${innerWidth}x${innerHeight}`);
        const bar = document.querySelector('.playback-bar:not([hidden])')?.getBoundingClientRect();
        for (const id of panels) {
          const r = document.querySelector(`section[data-panel="${id}"]`).getBoundingClientRect();
          if (r.left < 0 || r.top < 0 || r.right > innerWidth || r.bottom > innerHeight) problems.push(`${id} cut off`);
          if (bar && bar.height && r.bottom > bar.top) problems.push(`${id} under the playback bar`);
        }
        return problems; }""", panels)
    return found


def silent_panels(page: Any, panels: list[str], min_drawn: float = MIN_DRAWN) -> dict[str, float]:
    """Panels whose body draws (almost) nothing: one picture of the whole page, cut at each body's box (a screenshot
    per panel makes Chromium draw every WebGL view again each time, seconds apiece here)."""
    boxes: dict[str, list[float]] = page.evaluate("""(panels) => Object.fromEntries(panels.map((id) => {
        const r = document.querySelector(`section[data-panel="${id}"] > .panel-body`).getBoundingClientRect();
        return [id, [r.left, r.top, r.right, r.bottom]]; }))""", panels)
    whole = picture(page.screenshot(animations="disabled"))
    shares = {panel: drawn_share(whole.crop(tuple(round(v) for v in box))) for panel, box in boxes.items()}
    return {panel: share for panel, share in shares.items() if share < min_drawn}
