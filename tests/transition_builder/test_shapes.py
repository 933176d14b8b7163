"""Tests for transition_builder.shapes: geometry, convex parts, symmetry and validation."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Polygon
from shapely.ops import unary_union

from transition_builder.shapes import (
    MAX_CONVEX_PARTS,
    Shape,
    allen_key,
    check_fits,
    convex_decomposition,
    fits_in_tray,
    make_shape,
    parse_shape,
    random_triangle,
    symmetry_order,
)

SPECS = ["allen-key", "triangle:0", "triangle:7", "rectangle:40x20", "rectangle:30x30",
         "polygon:0,0;40,0;40,40;20,10;0,40", "polygon:0,0;0,30;30,30;30,0"]


def _star(n_points=5, r_out=40.0, r_in=15.0, phase=0.3):
    pts = []
    for i in range(2 * n_points):
        r = r_out if i % 2 == 0 else r_in
        a = phase + math.pi * i / n_points
        pts.append((r * math.cos(a), r * math.sin(a)))
    return pts


def _signed_area(v):
    x, y = v[:, 0], v[:, 1]
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


@pytest.mark.parametrize("spec", SPECS)
def test_ccw_centroid_area_mass(spec):
    s = parse_shape(spec)
    poly = Polygon(s.vertices)
    assert poly.is_valid
    assert _signed_area(s.vertices) > 0  # counter-clockwise
    np.testing.assert_allclose([poly.centroid.x, poly.centroid.y], [0, 0], atol=1e-9)
    assert s.area_mm2 == pytest.approx(poly.area, rel=1e-12)
    assert s.mass_kg == pytest.approx(poly.area * 1e-6 * s.thickness_mm * 1e-3 * s.density_kg_m3)
    assert s.name == spec


def test_allen_key_dimensions_and_inertia():
    s = parse_shape("allen-key")
    ext = np.ptp(s.vertices, axis=0)
    np.testing.assert_allclose(ext, [77.5, 27.5])
    assert s.area_mm2 == pytest.approx(77.5 * 6 + 21.5 * 6)
    assert s.density_kg_m3 == 7850.0 and s.thickness_mm == 5.0
    # inertia by brute force: fine grid over the bounding box, point-in-polygon by shapely
    from shapely import contains_xy
    h = 0.05
    xs = np.arange(s.vertices[:, 0].min() + h / 2, s.vertices[:, 0].max(), h)
    ys = np.arange(s.vertices[:, 1].min() + h / 2, s.vertices[:, 1].max(), h)
    X, Y = np.meshgrid(xs, ys)
    inside = contains_xy(Polygon(s.vertices), X, Y)
    j_mm4 = np.sum((X ** 2 + Y ** 2)[inside]) * h * h
    expected = s.density_kg_m3 * s.thickness_mm * 1e-3 * j_mm4 * 1e-12
    assert s.inertia_kg_m2 == pytest.approx(expected, rel=2e-3)


def test_rectangle_inertia_closed_form():
    s = parse_shape("rectangle:40x20")
    assert s.inertia_kg_m2 == pytest.approx(s.mass_kg * (0.04 ** 2 + 0.02 ** 2) / 12.0, rel=1e-12)


def test_allen_key_parameters():
    s = parse_shape("allen-key:arm=8,thickness=4")
    assert s.thickness_mm == 4.0
    assert s.area_mm2 == pytest.approx(77.5 * 8 + 19.5 * 8)
    assert allen_key(arm_width_mm=5).area_mm2 == pytest.approx(77.5 * 5 + 22.5 * 5)
    with pytest.raises(ValueError, match="unknown parameter"):
        parse_shape("allen-key:color=3")
    with pytest.raises(ValueError, match="arm width"):
        allen_key(arm_width_mm=30)


@pytest.mark.parametrize("spec", SPECS + ["polygon:" + ";".join(f"{x},{y}" for x, y in _star())])
def test_convex_parts_tile_the_polygon(spec):
    s = parse_shape(spec)
    assert 1 <= len(s.convex_parts) <= MAX_CONVEX_PARTS
    polys = []
    for p in s.convex_parts:
        assert _signed_area(p) > 0
        poly = Polygon(p)
        assert poly.is_valid
        assert poly.area == pytest.approx(poly.convex_hull.area, rel=1e-9)  # convex
        polys.append(poly)
    total = sum(p.area for p in polys)
    assert total == pytest.approx(s.area_mm2, rel=1e-9)  # no overlaps ...
    union = unary_union(polys)
    assert union.symmetric_difference(Polygon(s.vertices)).area < 1e-6 * s.area_mm2  # ... and no gaps


def test_convex_polygon_is_one_part_concave_is_several():
    assert len(parse_shape("rectangle:10x5").convex_parts) == 1
    assert len(parse_shape("allen-key").convex_parts) == 2  # an L is two convex pieces
    star = make_shape(_star(5))
    assert len(star.convex_parts) >= 5  # each spike needs its own part


def test_too_many_convex_parts_is_a_clear_error():
    comb = [(0.0, 0.0), (100.0, 0.0)]
    for i in range(20):  # 20 teeth, concave notches between them
        x = 100.0 - 5.0 * i
        comb += [(x, 10.0), (x - 2.5, 3.0)] if i < 19 else [(x, 10.0)]
    comb.append((0.0, 10.0))
    with pytest.raises(ValueError, match="convex parts"):
        make_shape(comb)


def test_clockwise_input_is_normalised():
    ccw = parse_shape("polygon:0,0;40,0;40,40;20,10;0,40")
    cw = parse_shape("polygon:0,40;20,10;40,40;40,0;0,0")
    assert _signed_area(cw.vertices) > 0
    assert Polygon(cw.vertices).symmetric_difference(Polygon(ccw.vertices)).area < 1e-9


def _rotated(points, angle, shift=(0.0, 0.0)):
    c, s = math.cos(angle), math.sin(angle)
    return [(c * x - s * y + shift[0], s * x + c * y + shift[1]) for x, y in points]


@pytest.mark.parametrize("points, order", [
    ([(0, 0), (30, 0), (30, 30), (0, 30)], 4),
    ([(0, 0), (30, 0), (15, 15 * math.sqrt(3))], 3),
    ([(0, 0), (40, 0), (40, 20), (0, 20)], 2),
    ([(0, 0), (77.5, 0), (77.5, 6), (6, 6), (6, 27.5), (0, 27.5)], 1),
    (_star(5), 5),
    ([(math.cos(2 * math.pi * i / 6), math.sin(2 * math.pi * i / 6)) for i in range(6)], 6),
    ([(0, 0), (40, 0), (40, 20), (20, 20), (20, 40), (0, 40)], 1),  # L with equal arms: mirror only
    ([(0, 0), (30, 0), (30, 10), (10, 10), (10, 30), (0, 30), (0, 0)][:-1], 1),
])
def test_symmetry_order(points, order):
    assert symmetry_order(points) == order
    # robust to rotation, translation, starting vertex, orientation, extra collinear vertices
    moved = _rotated(points, 0.7, (13.0, -4.0))
    assert symmetry_order(moved) == order
    assert symmetry_order(moved[2:] + moved[:2]) == order
    assert symmetry_order(moved[::-1]) == order
    mid = ((moved[0][0] + moved[1][0]) / 2, (moved[0][1] + moved[1][1]) / 2)
    assert symmetry_order([moved[0], mid] + moved[1:]) == order


def test_symmetry_tolerates_rounded_coordinates():
    tri = [(round(x, 3), round(y, 3)) for x, y in _rotated([(0, 0), (50, 0), (25, 25 * math.sqrt(3))], 0.4)]
    assert symmetry_order(tri) == 3
    sq = [(round(x, 2), round(y, 2)) for x, y in _rotated([(0, 0), (40, 0), (40, 40), (0, 40)], 1.1)]
    assert symmetry_order(sq) == 4  # coordinates to 0.01 mm
    assert symmetry_order([(0, 0), (30, 0), (30, 30.5), (0, 30.5)]) == 2  # not a square
    assert symmetry_order([(0, 0), (30, 0), (30, 30.2), (0, 30.2)]) == 2


@pytest.mark.parametrize("seed", range(15))
def test_random_triangles_are_reasonable(seed):
    s = parse_shape(f"triangle:{seed}")
    assert len(s.vertices) == 3
    assert s.symmetry_order == 1
    assert s.density_kg_m3 == allen_key().density_kg_m3
    assert 400 <= s.area_mm2 <= 1400
    v = s.vertices
    for i in range(3):  # no slivers: every angle >= 20 degrees
        a, b, c = v[i - 1], v[i], v[(i + 1) % 3]
        u, w = a - b, c - b
        ang = math.degrees(math.acos(np.dot(u, w) / (np.linalg.norm(u) * np.linalg.norm(w))))
        assert ang >= 20.0 - 1e-6
    assert check_fits(s, 200, 200)


def test_random_triangles_deterministic_and_distinct():
    a = random_triangle(3)
    b = parse_shape("triangle:3")
    np.testing.assert_array_equal(a.vertices, b.vertices)
    assert a.to_dict() == b.to_dict()
    areas = {round(parse_shape(f"triangle:{k}").area_mm2, 6) for k in range(15)}
    assert len(areas) == 15


def test_json_file(tmp_path):
    f = tmp_path / "part.json"
    f.write_text(json.dumps({"vertices": [[0, 0], [50, 0], [50, 10], [0, 10]], "thickness_mm": 3,
                             "density_kg_m3": 2700}))
    s = parse_shape(str(f))
    assert s.area_mm2 == pytest.approx(500)
    assert s.mass_kg == pytest.approx(500e-6 * 3e-3 * 2700)
    assert s.symmetry_order == 2
    json.dumps(s.to_dict())  # JSON-able


@pytest.mark.parametrize("content, message", [
    ("{not json", "not valid JSON"),
    (json.dumps({"verts": []}), "vertices"),
    (json.dumps({"vertices": [[0, 0], [1, 0], [0, 1]], "colour": 1}), "unknown key"),
    (json.dumps({"vertices": [[0, 0], [1, "a"], [0, 1]]}), "numbers"),
    (json.dumps({"vertices": [[0, 0], [1, 0], [0, 1]], "thickness_mm": -1}), "thickness"),
    (json.dumps({"vertices": [[0, 0], [1, 0]]}), "at least 3"),
])
def test_json_file_errors(tmp_path, content, message):
    f = tmp_path / "bad.json"
    f.write_text(content)
    with pytest.raises(ValueError, match=message):
        parse_shape(str(f))


@pytest.mark.parametrize("spec, message", [
    ("polygon:0,0;10,10", "at least 3 vertices"),
    ("polygon:0,0;10,10;10,0;0,10", "not simple"),
    ("polygon:0,0;10,0;10,10;0,10;5,-5", "not simple"),
    ("polygon:0,0;10,0;20,0", "zero area"),
    ("polygon:0,0;0,0;0,0", "zero area"),
    ("polygon:0,0;nan,0;1,1", "finite"),
    ("polygon:0,0;inf,0;1,1", "finite"),
    ("polygon:0,0;a,0;1,1", "not a number"),
    ("polygon:0,0;1,0;1", "x,y pair"),
    ("polygon:", "expected polygon"),
    ("rectangle:10", "rectangle:WxH"),
    ("rectangle:0x5", "positive"),
    ("rectangle:-3x5", "positive"),
    ("triangle:x", "non-negative integer"),
    ("triangle:-2", "non-negative integer"),
    ("hexagon", "unknown shape"),
    ("", "empty shape"),
    ("missing_file.json", "does not exist"),
])
def test_bad_specs_raise_one_line(spec, message):
    with pytest.raises(ValueError, match=message) as info:
        parse_shape(spec)
    assert "\n" not in str(info.value)


def test_make_shape_validation():
    with pytest.raises(ValueError, match="finite"):
        make_shape([(0, 0), (1, 0), (0, np.nan)])
    with pytest.raises(ValueError, match="pairs"):
        make_shape([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    with pytest.raises(ValueError, match="density"):
        make_shape([(0, 0), (1, 0), (0, 1)], density_kg_m3=0)


def test_fits_in_tray():
    key = parse_shape("allen-key")
    assert check_fits(key, 200, 200)
    assert fits_in_tray(key, 80, 30)  # just fits axis-aligned
    assert fits_in_tray(key, 70, 70)  # only diagonally
    assert not fits_in_tray(key, 50, 50)  # the 77.5 mm arm exceeds the 70.7 mm diagonal
    # a 250 x 10 rod fits only diagonally in a 200 x 200 tray (diagonal 282 mm)
    rod = parse_shape("rectangle:250x10")
    assert check_fits(rod, 200, 200)
    with pytest.raises(ValueError, match="does not fit"):
        check_fits(parse_shape("rectangle:300x10"), 200, 200)
    with pytest.raises(ValueError, match="positive"):
        check_fits(key, -1, 200)


def test_placed():
    s = parse_shape("rectangle:40x20")
    p = s.placed((100.0, 50.0, math.pi / 2))
    np.testing.assert_allclose(np.ptp(p, axis=0), [20, 40], atol=1e-12)
    np.testing.assert_allclose(p.mean(axis=0), [100, 50], atol=1e-12)
    batch = s.placed(np.array([[0, 0, 0], [10, 20, math.pi / 2]]))
    assert batch.shape == (2, 4, 2)
    np.testing.assert_allclose(batch[1], s.placed((10, 20, math.pi / 2)))


def test_shape_is_frozen_and_arrays_read_only():
    s = parse_shape("allen-key")
    assert isinstance(s, Shape)
    with pytest.raises(AttributeError):
        s.name = "x"
    with pytest.raises(ValueError):
        s.vertices[0, 0] = 1.0


def test_convex_decomposition_function_direct():
    parts = convex_decomposition(np.array(_star(4), dtype=float))
    assert sum(Polygon(p).area for p in parts) == pytest.approx(Polygon(_star(4)).area)




@st.composite
def star_polygons(draw):
    """Random star-shaped (hence simple) polygons, possibly with rounded (collinear) coordinates."""
    m = draw(st.integers(3, 12))
    gaps = draw(st.lists(st.floats(0.05, 1.0), min_size=m, max_size=m))
    ang = np.cumsum(gaps) / np.sum(gaps) * 2 * math.pi
    r = np.array(draw(st.lists(st.floats(5.0, 60.0), min_size=m, max_size=m)))
    pts = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
    if draw(st.booleans()):
        pts = np.round(pts)
    return pts


@settings(max_examples=150, deadline=None)
@given(star_polygons())
def test_property_random_simple_polygons(pts):
    try:
        s = make_shape(pts)
    except ValueError as exc:  # rounding can make a polygon degenerate; the error must say so
        assert "zero area" in str(exc) or "not simple" in str(exc) or "convex parts" in str(exc)
        assert not Polygon(pts).is_valid or Polygon(pts).area < 1e-6 or "convex parts" in str(exc)
        return
    assert _signed_area(s.vertices) > 0
    c = Polygon(s.vertices).centroid
    assert abs(c.x) < 1e-9 and abs(c.y) < 1e-9
    assert s.area_mm2 == pytest.approx(Polygon(pts).area, rel=1e-9)
    polys = [Polygon(p) for p in s.convex_parts]
    assert sum(p.area for p in polys) == pytest.approx(s.area_mm2, rel=1e-9)
    assert unary_union(polys).symmetric_difference(Polygon(s.vertices)).area < 1e-6 * s.area_mm2
    for p in polys:
        assert p.area == pytest.approx(p.convex_hull.area, rel=1e-9)


def test_shape_file_fields_are_checked(tmp_path):
    """A boolean thickness is not 1 mm, and a non-UTF-8 file is named."""
    from transition_builder.shapes import parse_shape

    f = tmp_path / "part.json"
    f.write_text('{"vertices": [[0, 0], [30, 0], [0, 20]], "thickness_mm": true}')
    with pytest.raises(ValueError, match="thickness_mm.*must be a number, got true"):
        parse_shape(str(f))
    f.write_bytes(b'{"vertices": [[0, 0], [30, 0], [0, 20]], "name": "\xff\xfe"}')
    with pytest.raises(ValueError, match="part.json.*not UTF-8"):
        parse_shape(str(f))
