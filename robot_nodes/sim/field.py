"""The Humanoid League kid-size field: dimensions, line segments and goal posts in field coordinates.

Field frame: origin at the centre mark, x towards the goal the robots attack (+x), y to the left,
z up; the same frame the ground truth and Position2D use. Dimensions from the HL rules (kid size).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class FieldDimensions:
    length: float = 9.0  # A, touchline length (goal line to goal line)
    width: float = 6.0  # B, goal line length
    goal_depth: float = 0.6  # C
    goal_width: float = 2.6  # D, between the inner edges of the posts
    goal_height: float = 1.2  # to the bottom of the crossbar
    goal_area_length: float = 1.0  # E
    goal_area_width: float = 3.0  # F
    penalty_mark_distance: float = 1.5  # G, from the goal line
    centre_circle_diameter: float = 1.5  # H
    border_strip: float = 1.0  # I, green beyond the lines
    penalty_area_length: float = 2.0  # J
    penalty_area_width: float = 5.0  # K
    line_width: float = 0.05
    post_diameter: float = 0.10
    # a FIFA size 1 ball (circumference about 0.47 m) as the kid-size rules ask
    ball_diameter: float = 0.15
    ball_mass: float = 0.18


KID_SIZE = FieldDimensions()


def line_segments(f: FieldDimensions = KID_SIZE, circle_pieces: int = 32) -> np.ndarray:
    """(n, 2, 2) segments [(x0, y0), (x1, y1)] along the middle of every white line."""
    hx, hy = f.length / 2, f.width / 2
    segs: list[tuple[tuple[float, float], tuple[float, float]]] = [
        ((-hx, hy), (hx, hy)),  # touchlines
        ((-hx, -hy), (hx, -hy)),
        ((-hx, -hy), (-hx, hy)),  # goal lines
        ((hx, -hy), (hx, hy)),
        ((0.0, -hy), (0.0, hy)),  # centre line
    ]
    for sx in (-1.0, 1.0):
        for length, width in ((f.goal_area_length, f.goal_area_width), (f.penalty_area_length, f.penalty_area_width)):
            x_in = sx * (hx - length)
            segs += [
                ((sx * hx, width / 2), (x_in, width / 2)),
                ((sx * hx, -width / 2), (x_in, -width / 2)),
                ((x_in, -width / 2), (x_in, width / 2)),
            ]
        # penalty mark: a cross of line-width bars, 0.1 m long
        px = sx * (hx - f.penalty_mark_distance)
        segs += [((px - 0.05, 0.0), (px + 0.05, 0.0)), ((px, -0.05), (px, 0.05))]
    segs += [((-0.05, 0.0), (0.05, 0.0))]  # centre mark
    r = f.centre_circle_diameter / 2
    for i in range(circle_pieces):
        a0, a1 = 2 * math.pi * i / circle_pieces, 2 * math.pi * (i + 1) / circle_pieces
        segs.append(((r * math.cos(a0), r * math.sin(a0)), (r * math.cos(a1), r * math.sin(a1))))
    return np.array(segs, dtype=float)


def goal_posts(f: FieldDimensions = KID_SIZE) -> np.ndarray:
    """(4, 2) post centres: [+x left, +x right, -x left, -x right], left/right as seen facing that goal."""
    hx = f.length / 2 + f.post_diameter / 2
    py = f.goal_width / 2 + f.post_diameter / 2
    return np.array([(hx, py), (hx, -py), (-hx, -py), (-hx, py)], dtype=float)
