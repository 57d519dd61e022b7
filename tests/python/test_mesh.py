"""qjulia.mesh(): the numbers of `qjulia mesh --stats` for the same parameters, numpy views."""

import gc

import numpy as np
import pytest

import qjulia
from conftest import cli_stats, mesh_figures

# Small resolutions keep the suite fast; both methods, with colours.
CASES = [
    ("newton-cubic", 32, "iterations"),
    ("classic-julia", 48, "iterations"),
    ("rosa-rational", 40, "basin"),
]


@pytest.mark.parametrize("preset,resolution,color", CASES)
def test_stats_equal_the_cli_stats(tmp_path, preset, resolution, color):
    cli, _ = cli_stats(tmp_path, "--preset", preset, "--resolution", resolution, "--color", color)
    m = qjulia.mesh(preset=preset, resolution=resolution, mesh={"color": color})
    assert m.stats["faces"] > 0
    assert mesh_figures(m.stats) == mesh_figures(cli)
    assert [stage for stage, _ in m.stats["timings"].items()] == list(cli["timings"])


@pytest.mark.parametrize("preset,resolution,color", CASES)
def test_arrays_equal_the_cli_mesh(tmp_path, preset, resolution, color):
    _, path = cli_stats(tmp_path, "--preset", preset, "--resolution", resolution, "--color", color)
    m = qjulia.mesh(preset=preset, resolution=resolution, mesh={"color": color})
    cli = qjulia.load(path)  # binary PLY: float32 positions, uint32 indices
    assert m.vertices.dtype == np.float32 and m.faces.dtype == np.uint32
    assert m.vertices.shape == (m.stats["vertices"], 3)
    assert m.faces.shape == (m.stats["faces"], 3)
    np.testing.assert_array_equal(m.vertices, cli.vertices)
    np.testing.assert_array_equal(m.faces, cli.faces)


def test_arrays_are_read_only_views_of_the_mesh():
    m = qjulia.mesh(preset="unit-ball", resolution=16, mesh={"color": "iterations"})
    for name in ("vertices", "faces", "normals", "colors"):
        a, b = getattr(m, name), getattr(m, name)
        assert np.shares_memory(a, b), f"{name} is copied on every access"
        assert not a.flags.writeable
        with pytest.raises(ValueError):
            a[0, 0] = 1


def test_arrays_are_the_meshs_memory_not_copies():
    m = qjulia.mesh(preset="unit-ball", resolution=16, mesh={"color": "iterations"})
    for name in ("vertices", "faces", "normals", "colors"):
        a = getattr(m, name)
        assert a.base is m, f"{name} is not a view owned by the mesh"
        assert not a.flags.owndata and a.flags.c_contiguous


def test_an_array_keeps_its_mesh_alive():
    vertices = qjulia.mesh(preset="unit-ball", resolution=16).vertices
    gc.collect()
    r = np.linalg.norm(vertices.astype(np.float64), axis=1)
    assert abs(r.mean() - 1) < 0.01


def test_normals_are_unit_and_colours_appear_only_when_asked():
    plain = qjulia.mesh(preset="classic-julia", resolution=28)
    assert plain.colors is None
    n = np.linalg.norm(plain.normals, axis=1)
    np.testing.assert_allclose(n, 1, atol=1e-5)
    colored = qjulia.mesh(preset="classic-julia", resolution=28, mesh={"color": "iterations"})
    assert colored.colors.shape == colored.vertices.shape
    assert colored.colors.min() >= 0 and colored.colors.max() <= 1
    assert len(np.unique(colored.colors, axis=0)) > 1


def test_unit_ball_is_closed_with_the_volume_of_the_ball():
    m = qjulia.mesh(preset="unit-ball", resolution=48)
    s = m.stats
    assert s["closed"] and s["manifold"] and s["oriented"]
    assert abs(s["volume"] - 4 / 3 * np.pi) < 0.05
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    np.testing.assert_allclose(lo, s["bbox"]["min"], atol=1e-6)
    np.testing.assert_allclose(hi, s["bbox"]["max"], atol=1e-6)


def test_size_scales_the_longest_side_to_millimetres(tmp_path):
    cli, _ = cli_stats(tmp_path, "--preset", "classic-julia", "--resolution", "28", "--size", "80mm")
    m = qjulia.mesh(preset="classic-julia", resolution=28, print={"size_mm": 80})
    assert m.unit == "mm"
    extent = m.vertices.max(axis=0) - m.vertices.min(axis=0)
    assert abs(extent.max() - 80) < 1e-3
    assert mesh_figures(m.stats) == mesh_figures(cli)


def test_decimation_through_mesh_faces_equals_the_cli(tmp_path):
    cli, _ = cli_stats(tmp_path, "--preset", "classic-julia", "--resolution", "40", "--faces", "2000")
    m = qjulia.mesh(preset="classic-julia", resolution=40, mesh={"faces": 2000})
    assert m.stats["faces"] <= 2000
    assert mesh_figures(m.stats) == mesh_figures(cli)


def test_an_empty_solid_gives_an_empty_mesh():
    # Newton's map with escape at R = 0.8: every orbit leaves the ball (README, table 1).
    m = qjulia.mesh(preset="newton-escape", bailout=0.8, resolution=16)
    assert m.vertices.shape == (0, 3) and m.faces.shape == (0, 3)
    assert m.stats["faces"] == 0


def test_mesh_from_arrays_checks_them():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int64)
    m = qjulia.Mesh(v, f)
    assert m.vertices.dtype == np.float32 and m.faces.dtype == np.uint32
    np.testing.assert_array_equal(m.faces, f)
    assert m.stats is None and m.params is None and m.normals is None
    with pytest.raises(ValueError, match="vertex index 4"):
        qjulia.Mesh(v, f + 1)
    with pytest.raises(ValueError, match="vertex index -1"):
        qjulia.Mesh(v, f - 1)
    with pytest.raises(ValueError, match="N x 3"):
        qjulia.Mesh(v[:, :2], f)
    with pytest.raises(ValueError, match="integer"):
        qjulia.Mesh(v, f.astype(np.float64))
    with pytest.raises(ValueError, match="colors: 3 rows for 4 vertices"):
        qjulia.Mesh(v, f, colors=np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"got shape \(\)"):
        qjulia.Mesh(None, f)
    with pytest.raises(ValueError, match="numbers"):
        qjulia.Mesh(np.array([["a", "b", "c"]]), f[:1] * 0)
    with pytest.raises(ValueError, match="vertex index"):
        qjulia.Mesh(v, np.array([[0, 1, 2**63]], np.uint64))
    bad = v.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="Mesh: vertex 2 has a non-finite position"):
        qjulia.Mesh(bad, f)
    # A cast would drop the imaginary parts without a word.
    with pytest.raises(ValueError, match="vertices: expected real numbers, not complex128"):
        qjulia.Mesh(v + 1j, f)
    with pytest.raises(ValueError, match="normals: expected real numbers"):
        qjulia.Mesh(v, f, normals=v.astype(np.complex64))


def test_strided_arrays_give_the_mesh_of_their_values():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int64)
    wide_v = np.zeros((4, 6))
    wide_v[:, ::2] = v
    wide_f = np.zeros((8, 3), np.int32)
    wide_f[::2] = f
    m = qjulia.Mesh(wide_v[:, ::2], np.asfortranarray(wide_f[::2]))
    np.testing.assert_array_equal(m.vertices, v)
    np.testing.assert_array_equal(m.faces, f)
