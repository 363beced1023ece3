"""Procedural art and image input for the bump maps and color textures (paper, sections 3.2 and 5; Fig. 9 and 11):
height fields (the Mexican hat of Fig. 9, a greyscale image, text chiselled into a rotten surface for Fig. 11) and
color textures (graffiti, a checkerboard, a constant or an image), all float64 or ``uint8``; the hardware's
quantization of them is :mod:`host.bumpmap`.

A height array ``h`` has shape ``(H, W)``: row ``i`` runs along ``v`` (top to bottom of the image), column ``j``
along ``u``. A color texture is ``uint8`` RGB of shape ``(H, W, 3)``, row 0 at ``v = 0``; a constant color is a
1 x 1 texture.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from host.scene import BumpSpec, ColorSpec

__all__ = ["mexican_hat", "heights_from_image", "chiselled_text", "height_field", "periodic_noise", "height_picture",
           "checker", "graffiti", "color_texture"]


# ------------------------------------------------------------------------------------------------------------
# height fields
# ------------------------------------------------------------------------------------------------------------
def mexican_hat(size=(40, 40), sigma: float | None = None) -> np.ndarray:
    """The paper's Mexican hat (Fig. 9) as a periodic height field.

    ``h(r) = (1 - r**2 / sigma**2) exp(-r**2 / (2 sigma**2))`` (the Ricker wavelet, peak 1 at ``r = 0``) centred
    on texel ``(H // 2, W // 2)`` (texel units, texel ``(i, j)`` at ``(x, y) = (j, i)``), summed over the 3 x 3
    neighbouring tiles so that the map tiles smoothly (for the default ``sigma`` the neighbours change the peak by
    about ``1e-12``; copies further away would add less than ``1e-50``).

    Parameters
    ----------
    size : (int, int)
        ``(width, height)`` in texels; the paper's map is 40 x 40.
    sigma : float, optional
        Width in texels (default ``min(size) / 8``).

    Returns
    -------
    ndarray, shape (height, width), float64
    """
    w, h = (int(x) for x in size)
    if w < 1 or h < 1:
        raise ValueError(f"size={size!r}: must be positive")
    sigma = min(w, h) / 8.0 if sigma is None else float(sigma)
    if not sigma > 0:
        raise ValueError(f"sigma={sigma!r}: must be > 0")
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    out = np.zeros((h, w))
    for ky in (-1, 0, 1):
        for kx in (-1, 0, 1):
            d2 = (x - w // 2 + kx * w) ** 2 + (y - h // 2 + ky * h) ** 2
            # a tiny sigma (5e-324 is > 0) makes sigma**2 underflow to 0 and r2 inf ((1 - inf) * 0 is NaN) or
            # 0 / 0 at the centre; beyond _R2_ZERO the term is exactly (1 - r2) * 0.0 in floats, so capping r2
            # there changes no bit of the sum for any other sigma
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                r2 = d2 / sigma ** 2
            r2 = np.where(d2 == 0, 0.0, np.minimum(r2, _R2_ZERO))
            out += (1.0 - r2) * np.exp(-0.5 * r2)
    return out


#: A squared radius (in sigmas) beyond which the Ricker wavelet's ``exp(-r2 / 2)`` is exactly 0.0 in float64
#: (it underflows below ``exp(-745.2)``): :func:`mexican_hat` caps r2 here.
_R2_ZERO = 2000.0


def heights_from_image(image) -> np.ndarray:
    """Heights in ``[0, 1]`` from a greyscale image (white = high), shape ``(H, W)``, row 0 = top = ``v = 0``.

    ``image`` is a path or a ``PIL.Image``. 16-bit greyscale is divided by 65535, everything else is converted to
    8-bit greyscale (``L``, ITU-R 601 luma for color images) and divided by 255.
    """
    from PIL import Image
    im = Image.open(image) if isinstance(image, (str, Path)) else image
    try:
        if im.mode in ("I;16", "I;16B", "I;16L", "I"):
            return np.clip(np.asarray(im, dtype=np.float64) / 65535.0, 0.0, 1.0)
        return np.asarray(im.convert("L"), dtype=np.float64) / 255.0
    finally:
        if im is not image:
            im.close()


def _fade(t):
    return t * t * t * (t * (t * 6 - 15) + 10)          # C2 smoothstep: no creases in the derivatives


def periodic_noise(shape, cells, rng) -> np.ndarray:
    """Periodic value noise in ``[0, 1]`` of ``shape`` ``(H, W)`` from a ``cells`` = ``(cy, cx)`` random lattice,
    interpolated with a C2 fade (so its central differences are smooth); it tiles with period ``shape``."""
    h, w = shape
    cy, cx = max(1, int(cells[0])), max(1, int(cells[1]))
    lat = rng.random((cy, cx))
    y = (np.arange(h) + 0.5) * cy / h
    x = (np.arange(w) + 0.5) * cx / w
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = _fade(y - y0)[:, None], _fade(x - x0)[None, :]
    y0, x0 = y0 % cy, x0 % cx
    y1, x1 = (y0 + 1) % cy, (x0 + 1) % cx
    a, b = lat[y0][:, x0], lat[y0][:, x1]
    c, d = lat[y1][:, x0], lat[y1][:, x1]
    return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy


def _fractal(shape, rng, base_cells=4, octaves=5) -> np.ndarray:
    h, w = shape
    out = np.zeros(shape)
    amp, total = 1.0, 0.0
    for k in range(octaves):
        n = base_cells * 2 ** k
        out += amp * periodic_noise(shape, (max(1, round(n * h / max(h, w))), max(1, round(n * w / max(h, w)))),
                                    rng)
        total += amp
        amp *= 0.5
    return out / total


def _fit_font(draw, text: str, font_size: int, max_w: float, max_h: float):
    from PIL import ImageFont
    size = int(font_size)
    while True:
        font = ImageFont.load_default(size=size)
        left, t, r, b = draw.multiline_textbbox((0, 0), text, font=font, align="center")
        if (r - left <= max_w and b - t <= max_h) or size <= 4:
            return font
        size = max(4, int(size * 0.9))


def chiselled_text(size=(512, 256), text="Berlin Hauptstadt", font_size=None, depth=0.6, bevel=1.5,
                   rot=0.25, seed=1995) -> np.ndarray:
    """A rotten wall with text chiselled into it (paper Fig. 11), heights in ``[0, 1]``.

    The text is drawn with Pillow (``ImageFont.load_default(size=font_size)``, centred; the font shrinks until
    the text fits 92 % of the width and 80 % of the height; ``\\n`` makes several lines); its mask, blurred by a
    Gaussian of ``bevel`` texels (the chisel's sloped walls), is carved ``depth`` deep into a surface at height 1.
    The rot is periodic fractal value noise of amplitude ``rot`` plus eroded patches (where a second noise is
    high) and round pits of 1 to 4 texels (kept off the border, so the map still tiles). The result is rescaled
    to ``[0, 1]``. Deterministic for a given ``seed`` and Pillow version.

    Returns
    -------
    ndarray, shape (size[1], size[0]), float64
    """
    from PIL import Image, ImageDraw, ImageFilter
    w, h = (int(x) for x in size)
    rng = np.random.default_rng(seed)
    font_size = max(4, h // 5) if font_size is None else int(font_size)
    mask = Image.new("L", (w, h), 0)
    draw = ImageDraw.Draw(mask)
    font = _fit_font(draw, text, font_size, 0.92 * w, 0.8 * h)
    draw.multiline_text((w / 2, h / 2), text, fill=255, font=font, anchor="mm", align="center")
    if bevel > 0:
        mask = mask.filter(ImageFilter.GaussianBlur(bevel))
    carve = np.asarray(mask, dtype=np.float64) / 255.0
    heights = 1.0 - depth * carve
    if rot > 0:
        heights += rot * (_fractal((h, w), rng) - 0.5)                 # weathered, uneven surface
        patches = _fractal((h, w), rng, base_cells=3, octaves=3)         # eroded patches
        heights -= rot * np.clip((patches - 0.62) / 0.2, 0.0, 1.0) ** 2
        pit = Image.new("L", (w, h), 0)                                  # round pits, 1..4 texels
        pd = ImageDraw.Draw(pit)
        for _ in range(w * h // 700):
            r = rng.uniform(1.0, 4.0)
            x, y = rng.uniform(r + 2, max(r + 2, w - r - 2)), rng.uniform(r + 2, max(r + 2, h - r - 2))
            pd.ellipse((x - r, y - r, x + r, y + r), fill=int(rng.uniform(120, 255)))
        heights -= rot * 0.8 * np.asarray(pit.filter(ImageFilter.GaussianBlur(1.0)), np.float64) / 255.0
    lo, hi = heights.min(), heights.max()
    return (heights - lo) / (hi - lo) if hi > lo else np.zeros_like(heights)


def height_field(spec: BumpSpec) -> np.ndarray:
    """The height array ``(H, W)`` of a scene's bump spec (file or procedural)."""
    if spec.kind == "file":
        return heights_from_image(spec.path)
    kw = spec.kwargs
    if spec.procedural == "mexican-hat":
        return mexican_hat(kw["size"], kw["sigma"])
    if spec.procedural == "chiselled-text":
        return chiselled_text(**kw)
    raise ValueError(f"{spec.key}: unknown bump procedural {spec.procedural!r}")


# ------------------------------------------------------------------------------------------------------------
# color textures
# ------------------------------------------------------------------------------------------------------------
def _to_uint8(x) -> np.ndarray:
    return np.floor(np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def height_picture(heights) -> np.ndarray:
    """A height field in ``[0, 1]`` as 8-bit grey (white = high), rounded half up, clipped."""
    return _to_uint8(heights)


def checker(size=(64, 64), checks=(8, 8), colors=((1.0, 1.0, 1.0), (0.1, 0.1, 0.1))) -> np.ndarray:
    """A checkerboard of ``checks = (cu, cv)`` squares, ``uint8 (size[1], size[0], 3)``; texel (0, 0) has
    ``colors[0]``. Handy for seeing perspective-correct texturing."""
    w, h = size
    j = (np.arange(w) * checks[0]) // w
    i = (np.arange(h) * checks[1]) // h
    odd = ((i[:, None] + j[None, :]) % 2).astype(bool)
    c = _to_uint8(colors)
    return np.where(odd[..., None], c[1], c[0]).astype(np.uint8)


_GRAFFITI_WORDS = ("BERLIN", "FREIHEIT", "1989", "MAUER", "LOVE", "WALL", "PEACE", "KUNST")


def graffiti(size=(256, 128), seed: int = 1) -> np.ndarray:
    """A procedural graffiti painting on grey concrete (paper Fig. 11 middle), ``uint8 (size[1], size[0], 3)``.

    Stained concrete (periodic value noise), then in random bright colors: nine spray strokes along wavy arcs, six
    outlined bubbles, and three tags in the top and bottom bands (words drawn with Pillow's default font,
    outlined, slightly rotated), so the middle band stays free for the chiselled text of the bump map. The
    content does not depend on the resolution.
    Drawn at twice the size and filtered down (antialiasing). Deterministic for a given ``seed`` and Pillow.
    """
    from PIL import Image, ImageDraw, ImageFilter, ImageFont
    w, h = (int(x) for x in size)
    rng = np.random.default_rng(seed)
    W, H = 2 * w, 2 * h
    concrete = 0.58 + 0.18 * (_fractal((H, W), rng, base_cells=4, octaves=5) - 0.5)
    concrete += 0.05 * (rng.random((H, W)) - 0.5)
    base = np.stack([concrete * 1.00, concrete * 0.98, concrete * 0.94], -1)
    img = Image.fromarray(_to_uint8(base), "RGB").convert("RGBA")
    palette = np.array([(230, 30, 60), (250, 200, 20), (30, 170, 230), (40, 200, 90), (240, 110, 20),
                        (190, 60, 210), (250, 250, 250), (20, 20, 25), (250, 90, 170)])

    def color():
        c = palette[rng.integers(len(palette))].astype(float) * rng.uniform(0.8, 1.0)
        return tuple(int(x) for x in c) + (int(rng.uniform(200, 255)),)

    layer = Image.new("RGBA", (W, H), (0, 0, 0, 0))
    d = ImageDraw.Draw(layer)
    scale = min(W, H)
    for _ in range(9):                                                 # spray strokes: wavy arcs
        t = np.linspace(0.0, 1.0, 24)[:, None]
        start = rng.uniform((0, 0), (W, H))
        ang = rng.uniform(0, 2 * np.pi)
        along, across = np.array([np.cos(ang), np.sin(ang)]), np.array([-np.sin(ang), np.cos(ang)])
        length = rng.uniform(0.3, 0.9) * scale
        wave = rng.uniform(0.03, 0.12) * scale * np.sin(rng.uniform(3, 9) * t + rng.uniform(0, 6))
        p = start + t * length * along + wave * across
        d.line([tuple(q) for q in p], fill=color(), width=int(rng.uniform(0.015, 0.045) * scale) + 1,
               joint="curve")
    for _ in range(6):                                                 # outlined bubbles
        cx, cy = rng.uniform(0, W), rng.uniform(0, H)
        rx, ry = rng.uniform(0.06, 0.16) * scale, rng.uniform(0.05, 0.12) * scale
        d.ellipse((cx - rx, cy - ry, cx + rx, cy + ry), fill=color(), outline=(15, 15, 20, 255),
                  width=max(2, int(0.015 * scale)))
    img = Image.alpha_composite(img, layer.filter(ImageFilter.GaussianBlur(0.004 * scale + 0.5)))
    for k in range(3):                                                 # tags, in the top and bottom bands
        word = _GRAFFITI_WORDS[rng.integers(len(_GRAFFITI_WORDS))]
        font = ImageFont.load_default(size=int(rng.uniform(0.16, 0.24) * H))
        cx, cy = (k + 0.5 + rng.uniform(-0.15, 0.15)) * W / 3, (0.17 if k % 2 == 0 else 0.83) * H
        sw = max(1, int(0.012 * H))
        left, t, r, b = d.textbbox((0, 0), word, font=font, anchor="mm", stroke_width=sw)
        tag = Image.new("RGBA", (r - left + 2 * sw + 4, b - t + 2 * sw + 4), (0, 0, 0, 0))
        ImageDraw.Draw(tag).text((tag.width / 2, tag.height / 2), word, font=font, anchor="mm", fill=color(),
                                 stroke_width=sw, stroke_fill=(10, 10, 10, 255))
        tag = tag.rotate(float(rng.uniform(-15, 15)), resample=Image.BICUBIC, expand=True)
        x0, y0 = int(round(cx - tag.width / 2)), int(round(cy - tag.height / 2))
        src = (max(0, -x0), max(0, -y0))
        tag = tag.crop((src[0], src[1], min(tag.width, W - x0), min(tag.height, H - y0)))
        if tag.width > 0 and tag.height > 0:
            img.alpha_composite(tag, (max(0, x0), max(0, y0)))
    img = img.convert("RGB").resize((w, h), Image.LANCZOS)
    return np.asarray(img, dtype=np.uint8).copy()


def color_texture(spec: ColorSpec) -> np.ndarray:
    """The ``uint8`` RGB texture ``(H, W, 3)`` of a scene's color spec (row 0 at ``v = 0``); a constant color is
    a 1 x 1 texture (``round_half_up(255 c)``)."""
    if spec.kind == "rgb":
        return _to_uint8(spec.rgb).reshape(1, 1, 3)
    if spec.kind == "file":
        from PIL import Image
        with Image.open(spec.path) as im:
            return np.asarray(im.convert("RGB"), dtype=np.uint8).copy()
    kw = spec.kwargs
    if spec.procedural == "graffiti":
        return graffiti(kw["size"], kw["seed"])
    if spec.procedural == "checker":
        return checker(kw["size"], kw["checks"], kw["colors"])
    raise ValueError(f"{spec.key}: unknown color procedural {spec.procedural!r}")
