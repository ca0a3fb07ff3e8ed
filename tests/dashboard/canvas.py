"""Reading what the page drew: a canvas pixel and a legend swatch's colour, as [r, g, b]."""

from __future__ import annotations

__all__ = ["LEGEND_BORDER_RGB", "LEGEND_RGB", "PIXEL"]

PIXEL = """([x, y]) => {
    const canvas = document.getElementById('floor');
    const rect = canvas.getBoundingClientRect();
    const k = canvas.width / rect.width;
    const px = canvas.getContext('2d').getImageData(
        Math.round((x - rect.left) * k), Math.round((y - rect.top) * k), 1, 1).data;
    return [px[0], px[1], px[2]];
}"""
"""The floor canvas's colour at viewport point ``[x, y]``."""

LEGEND_RGB = """(selector) => getComputedStyle(document.querySelector(selector))
    .backgroundColor.match(/\\d+/g).slice(0, 3).map(Number)"""
"""The fill colour of a legend swatch."""

LEGEND_BORDER_RGB = """(selector) => getComputedStyle(document.querySelector(selector))
    .borderTopColor.match(/\\d+/g).slice(0, 3).map(Number)"""
"""The outline colour of a legend swatch."""
