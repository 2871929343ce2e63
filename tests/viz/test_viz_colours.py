"""The viewer's overlay colours (force arrows, eccentricity, traces) are never body colours:
bodies are pastel, overlays fully saturated, so an arrow stands out against any link."""
from __future__ import annotations

import colorsys

import pytest

from pinclear.viz import geometry, scene

OVERLAYS = {"eccentricity": scene.ECC_COLOR, "normal force": scene.NORMAL_COLOR,
            "friction force": scene.FRICTION_COLOR, "trace": scene.TRACE_COLOR,
            "prescribed": scene.PRESCRIBED_COLOR}


def hsv(c):
    return colorsys.rgb_to_hsv(((c >> 16) & 255) / 255, ((c >> 8) & 255) / 255, (c & 255) / 255)


def rgb(c):
    return (c >> 16) & 255, (c >> 8) & 255, c & 255


@pytest.mark.parametrize("name", sorted(OVERLAYS))
def test_overlay_colours_differ_from_every_body_colour(name):
    """Saturation apart by more than half the scale for the first 64 bodies (the hue wheel
    repeats no colour; a mechanism with more bodies gets the same pastel band), and a
    clear RGB distance (> 100 of 441) to each."""
    s_over = hsv(OVERLAYS[name])[1]
    assert s_over > 0.95
    for k in range(64):
        c = geometry.body_color(k, 64)
        assert s_over - hsv(c)[1] > 0.5, (name, k, hex(c))
        assert sum((a - b) ** 2 for a, b in zip(rgb(c), rgb(OVERLAYS[name]))) ** 0.5 > 100, (name, k, hex(c))


def test_overlay_colours_differ_from_each_other_and_the_ground():
    cols = list(OVERLAYS.values()) + [geometry.GROUND_COLOR]
    for i, a in enumerate(cols):
        for b in cols[i + 1:]:
            assert sum((x - y) ** 2 for x, y in zip(rgb(a), rgb(b))) ** 0.5 > 100, (hex(a), hex(b))
