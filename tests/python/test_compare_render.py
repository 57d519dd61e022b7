"""qjulia.compare() and qjulia.render(): the CLI's `compare --json` and `render`."""

import json

import numpy as np
import pytest

import qjulia
from conftest import read_png, run_cli

SAMPLES = 20000


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """Two surfaces of one set (two resolutions), as meshes and as the CLI's files."""
    d = tmp_path_factory.mktemp("pair")
    a = qjulia.mesh(preset="classic-julia", resolution=32)
    b = qjulia.mesh(preset="classic-julia", resolution=20)
    a.save(d / "a.ply")
    b.save(d / "b.ply")
    return a, b, d / "a.ply", d / "b.ply"


def test_compare_equals_compare_json_of_the_cli(tmp_path, pair):
    _, _, pa, pb = pair
    run_cli("compare", pa, pb, "--samples", SAMPLES, "--quiet", "--json", tmp_path / "c.json")
    cli = json.loads((tmp_path / "c.json").read_text())
    ours = qjulia.compare(str(pa), str(pb), samples=SAMPLES)
    assert ours == cli
    assert 0 < ours["hausdorff"] < 0.5  # a box of side 3


def test_compare_takes_meshes_and_arrays_alike(pair):
    a, b, _, _ = pair
    meshes = qjulia.compare(a, b, samples=SAMPLES)
    arrays = qjulia.compare((a.vertices, a.faces), (b.vertices, b.faces), samples=SAMPLES)
    assert meshes == arrays
    assert meshes["a"]["faces"] == a.stats["faces"] and meshes["b"]["faces"] == b.stats["faces"]
    assert meshes["a_name"] == "a" and meshes["b_name"] == "b"


def test_a_mesh_compared_with_itself_is_at_distance_zero(pair):
    a = pair[0]
    assert qjulia.compare(a, a, samples=SAMPLES)["hausdorff"] < 1e-4


def test_compare_seed_changes_the_random_samples_only(pair):
    a, b, _, _ = pair
    one = qjulia.compare(a, b, samples=SAMPLES, seed=1)
    two = qjulia.compare(a, b, samples=SAMPLES, seed=2)
    assert one["a"] == two["a"] and one["a_to_b"]["mean"] != two["a_to_b"]["mean"]


def test_compare_takes_strided_arrays_of_any_number_type(pair):
    a, b, _, _ = pair
    wide = np.zeros((len(a.vertices), 6))
    wide[:, 1::2] = a.vertices
    faces = np.asfortranarray(a.faces.astype(np.int64))
    assert qjulia.compare((wide[:, 1::2], faces), b, samples=SAMPLES) == \
        qjulia.compare(a, b, samples=SAMPLES)


def test_compare_of_bad_arrays_is_a_value_error(pair):
    a, b = pair[0], pair[1]
    for bad in [(a.vertices[:, :2], a.faces), (a.vertices, a.faces.astype(np.float32)),
                (a.vertices, a.faces + len(a.vertices)), (np.full_like(a.vertices, np.nan), a.faces),
                (np.zeros((0, 3)), np.zeros((0, 3), np.uint32))]:
        with pytest.raises(ValueError):
            qjulia.compare(bad, b, samples=SAMPLES)


def test_compare_of_a_wrong_thing_is_a_type_error(pair):
    with pytest.raises(TypeError):
        qjulia.compare(pair[0], 3)


def test_compare_samples_and_seed_are_checked_as_the_cli_checks_them(pair):
    for bad in [-1, qjulia._core.MOST_COMPARE_SAMPLES + 1]:
        with pytest.raises(ValueError, match=f"samples: expected an integer in 0..100000000, "
                                             f"not {bad}"):
            qjulia.compare(pair[0], pair[1], samples=bad)
    with pytest.raises(ValueError, match="seed"):
        qjulia.compare(pair[0], pair[1], seed=-5)
    for bad in [1.5, "100", True]:
        with pytest.raises(TypeError, match="samples must be an integer"):
            qjulia.compare(pair[0], pair[1], samples=bad)
    # numpy integers are integers.
    assert qjulia.compare(pair[0], pair[1], samples=np.int64(SAMPLES)) == \
        qjulia.compare(pair[0], pair[1], samples=SAMPLES)


def test_render_equals_the_cli_image(tmp_path, pair):
    m = qjulia.mesh(preset="classic-julia", resolution=28, mesh={"color": "iterations"})
    m.save(tmp_path / "m.ply")
    run_cli("render", tmp_path / "m.ply", "-o", tmp_path / "m.png", "--size", "72x48",
            "--shading", "lambert", "--rotate=-25,-35,0")
    options = dict(width=72, height=48, shading="lambert", rotate=(-25, -35, 0))
    cli = read_png(tmp_path / "m.png")
    ours = qjulia.render(tmp_path / "m.ply", **options)  # the mesh the CLI read
    assert ours.shape == (48, 72, 3) and ours.dtype == np.uint8
    np.testing.assert_array_equal(ours, cli)
    assert len(np.unique(ours.reshape(-1, 3), axis=0)) > 10
    # The mesh itself: its colours unrounded (PLY holds them in 8-bit sRGB).
    direct = qjulia.render(m, **options).astype(int)
    assert np.abs(direct - cli).max() <= 1


def test_save_png_writes_the_image(tmp_path, pair):
    image = qjulia.render(pair[0], width=50, height=40, shading="phong")
    qjulia.save_png(tmp_path / "i.png", image)
    np.testing.assert_array_equal(read_png(tmp_path / "i.png"), image)
    with pytest.raises(ValueError, match="H x W x 3"):
        qjulia.save_png(tmp_path / "j.png", image[:, :, :2])
    with pytest.raises(FileNotFoundError):
        qjulia.save_png(tmp_path / "no" / "i.png", image)
    # No silent wrap-around: other integer types only with values 0..255, no floats.
    qjulia.save_png(tmp_path / "k.png", image.astype(np.int64))
    np.testing.assert_array_equal(read_png(tmp_path / "k.png"), image)
    with pytest.raises(ValueError, match="value -1 is not in 0..255"):
        qjulia.save_png(tmp_path / "l.png", np.where(image == image.max(), -1, image))
    with pytest.raises(ValueError, match="float64"):
        qjulia.save_png(tmp_path / "l.png", image / 255.0)
    assert not (tmp_path / "l.png").exists()
    # PNG bytes go to a .png only, as `qjulia render -o` and `--preview` refuse another name.
    with pytest.raises(ValueError, match="must end in .png"):
        qjulia.save_png(tmp_path / "i.jpg", image)
    assert not (tmp_path / "i.jpg").exists()


def test_render_uses_the_library_defaults_and_checks_options(pair):
    a = pair[0]
    image = qjulia.render(a, width=40, height=30, background=(0, 0, 0))
    assert image.shape == (30, 40, 3)
    assert (image[0, 0] == 0).all() and image.max() > 0
    with pytest.raises(ValueError, match="shading: .glossy. is not simple, lambert or phong"):
        qjulia.render(a, shading="glossy")
    with pytest.raises(ValueError, match="framing: 'tight' is not box or sphere"):
        qjulia.render(a, framing="tight")
    with pytest.raises(ValueError):
        qjulia.render(a, width=0)
    with pytest.raises(TypeError, match="sizee"):
        qjulia.render(a, sizee=3)
