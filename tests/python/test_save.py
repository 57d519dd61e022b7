"""Mesh.save(): every format of `qjulia mesh -o`, written as the CLI writes it."""

import json

import numpy as np
import pytest

import qjulia
from conftest import run_cli

ARGS = ("--preset", "rosa-rational", "--resolution", "32", "--color", "iterations")


@pytest.fixture(scope="module")
def rosa():
    return qjulia.mesh(preset="rosa-rational", resolution=32, mesh={"color": "iterations"})


def companions(path):
    """The files `qjulia mesh -o path` writes besides path."""
    if path.suffix == ".gltf":
        return [path.with_suffix(".bin")]
    if path.suffix == ".stl":
        return [path.with_name(path.name + ".json")]
    return []


@pytest.mark.parametrize("ext", ["glb", "gltf", "obj", "ply", "stl", "3mf"])
def test_save_writes_the_bytes_the_cli_writes(tmp_path, rosa, ext):
    ours, theirs = tmp_path / "ours", tmp_path / "cli"
    ours.mkdir()
    theirs.mkdir()
    rosa.save(str(ours / f"m.{ext}"))
    run_cli("mesh", *ARGS, "--quiet", "-o", theirs / f"m.{ext}")
    for a in [ours / f"m.{ext}", *companions(ours / f"m.{ext}")]:
        b = theirs / a.name
        assert a.read_bytes() == b.read_bytes(), f"{a.name} differs from the CLI's"
    assert sorted(p.name for p in ours.iterdir()) == sorted(p.name for p in theirs.iterdir())


def test_save_3mf_equals_the_cli_mesh_and_parameters(tmp_path, rosa):
    # What the 3MF holds, read back.
    rosa.save(tmp_path / "ours.3mf")
    run_cli("mesh", *ARGS, "--quiet", "-o", tmp_path / "cli.3mf")
    ours, cli = qjulia.load(tmp_path / "ours.3mf"), qjulia.load(tmp_path / "cli.3mf")
    np.testing.assert_array_equal(ours.vertices, cli.vertices)
    np.testing.assert_array_equal(ours.faces, cli.faces)
    assert ours.params == cli.params == rosa.params


@pytest.mark.parametrize("ext", ["glb", "gltf", "obj", "ply"])
def test_every_format_records_the_parameters(tmp_path, rosa, ext):
    path = tmp_path / f"m.{ext}"
    rosa.save(path)
    back = qjulia.load(path)
    assert back.params == rosa.params
    assert back.faces.shape == rosa.faces.shape
    again = qjulia.mesh(back.params)
    assert again.stats["faces"] == rosa.stats["faces"]


def test_stl_records_the_parameters_in_a_sidecar(tmp_path, rosa):
    rosa.save(tmp_path / "m.stl")
    assert json.loads((tmp_path / "m.stl.json").read_text()) == rosa.params


def test_a_printing_size_is_recorded_in_millimetres(tmp_path):
    m = qjulia.mesh(preset="classic-julia", resolution=16, print={"size_mm": 50})
    m.save(tmp_path / "m.stl")
    run_cli("mesh", "--preset", "classic-julia", "--resolution", "16", "--size", "50mm",
            "--quiet", "-o", tmp_path / "cli.stl")
    assert (tmp_path / "m.stl").read_bytes()[:80] == (tmp_path / "cli.stl").read_bytes()[:80]
    assert b"mm" in (tmp_path / "m.stl").read_bytes()[:80]


def test_vdb_needs_a_mesh_made_with_vdb(tmp_path, rosa):
    with pytest.raises(ValueError, match="vdb=True"):
        rosa.save(tmp_path / "grid.vdb")
    assert not (tmp_path / "grid.vdb").exists()
    m = qjulia.mesh(preset="rosa-rational", resolution=32, vdb=True)
    assert m.has_grid and not rosa.has_grid
    m.save(tmp_path / "grid.vdb")
    run_cli("mesh", "--preset", "rosa-rational", "--resolution", "32", "--quiet",
            "--vdb", tmp_path / "cli.vdb", "-o", tmp_path / "cli.ply")
    ours, cli = (tmp_path / "grid.vdb").read_bytes(), (tmp_path / "cli.vdb").read_bytes()
    assert ours[:4] == b" BDV"  # OpenVDB's magic number 0x56444220, little-endian
    assert len(ours) == len(cli)  # the same grid (the files differ only in their UUID)


def test_an_unknown_extension_is_a_value_error(tmp_path, rosa):
    with pytest.raises(ValueError, match="unknown output format '.xyz'"):
        rosa.save(tmp_path / "m.xyz")
    assert list(tmp_path.iterdir()) == []


def test_a_missing_directory_is_an_os_error_and_leaves_nothing(tmp_path, rosa):
    for ext in ("glb", "ply", "stl", "3mf"):
        with pytest.raises(OSError):
            rosa.save(tmp_path / "no" / f"m.{ext}")
    assert list(tmp_path.iterdir()) == []


def test_an_empty_mesh_cannot_be_saved(tmp_path):
    empty = qjulia.mesh(preset="newton-escape", bailout=0.8, resolution=16)
    with pytest.raises(ValueError, match="empty"):
        empty.save(tmp_path / "m.glb")
    assert list(tmp_path.iterdir()) == []


def test_a_mesh_from_arrays_saves_without_parameters(tmp_path):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.uint32)
    qjulia.Mesh(v, f).save(tmp_path / "t.ply")
    back = qjulia.load(tmp_path / "t.ply")
    np.testing.assert_array_equal(back.vertices, v)
    np.testing.assert_array_equal(back.faces, f)
    assert back.params is None


def test_a_path_with_a_nul_is_a_value_error_and_writes_nothing(tmp_path, rosa):
    # The C library would take the part before the NUL as the file's name.
    with pytest.raises(ValueError, match="null byte"):
        rosa.save(str(tmp_path / "m") + "\0.glb")
    assert list(tmp_path.iterdir()) == []
    rosa.save(tmp_path / "m.glb")
    with pytest.raises(ValueError, match="null byte"):  # not a read of m.glb
        qjulia.load(str(tmp_path / "m.glb") + "\0.ply")


def test_loading_a_missing_file_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError):
        qjulia.load(tmp_path / "missing.glb")


def test_loading_a_broken_file_is_a_value_error_naming_it(tmp_path):
    path = tmp_path / "broken.ply"
    path.write_bytes(b"ply\nformat nonsense\n")
    with pytest.raises(ValueError, match="broken.ply"):
        qjulia.load(path)
