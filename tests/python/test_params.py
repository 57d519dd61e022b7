"""Presets, parameter files and overrides: the same as the CLI's, with the CLI's messages."""

import json

import numpy as np
import pytest

import qjulia
from conftest import cli_error, run_cli


def test_presets_are_the_cli_presets_with_their_descriptions():
    listed = {}
    for line in run_cli("presets").stdout.splitlines():
        name, description = line.split(None, 1)
        listed[name] = description.strip()
    assert qjulia.presets() == listed
    assert list(qjulia.presets()) == list(listed)


@pytest.mark.parametrize("name", ["rosa-rational", "quaternion-mandelbrot"])
def test_params_of_a_preset_equal_qjulia_params(name):
    assert qjulia.params(name) == json.loads(run_cli("params", "--preset", name).stdout)


def test_params_without_a_preset_are_the_newton_cubic():
    assert qjulia.params() == json.loads(run_cli("params").stdout)
    assert qjulia.params() == qjulia.params("newton-cubic")


def test_overrides_equal_the_cli_flags():
    ours = qjulia.params("classic-julia", iterations=7, resolution=40, bailout=3.5,
                         constants={"c": [-0.1, 0.7, 0.1, 0]}, slice={"axes": "rmp", "fixed": 0.1},
                         bounds={"min": [-1.4, -1.3, -1.2], "max": [1.2, 1.3, 1.4]},
                         mesh={"faces": 500, "color": "basin"}, print={"size_mm": 60})
    cli = run_cli("params", "--preset", "classic-julia", "--iterations", "7", "--resolution", "40",
                  "--bailout", "3.5", "--const", "c=-0.1,0.7,0.1,0", "--axes", "rmp",
                  "--fixed", "0.1", "--bounds=-1.4,-1.3,-1.2,1.2,1.3,1.4", "--faces", "500",
                  "--color", "basin", "--size", "60mm").stdout
    assert ours == json.loads(cli)


def test_a_nested_override_updates_its_section_and_keeps_the_other_keys():
    base = qjulia.params("rosa-rational")
    assert base["mesh"]["clip"], "rosa-rational is cut open"
    changed = qjulia.params("rosa-rational", mesh={"faces": 1000})
    assert changed["mesh"]["faces"] == 1000
    assert changed["mesh"]["clip"] == base["mesh"]["clip"]
    assert changed["mesh"]["color"] == base["mesh"]["color"]


def test_a_new_constant_is_added_and_the_others_kept():
    p = qjulia.params("pq-quadratic", constants={"s": [1, 0, 0, 0]})
    assert set(p["constants"]) == {"p", "q", "s"}


def test_slice_axes_replace_a_general_slice_as_the_axes_flag_does():
    general = {"origin": [0, 0, 0, 0.2],
               "directions": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]]}
    assert qjulia.params(slice=general)["slice"] == {
        "origin": [0, 0, 0, 0.2], "directions": general["directions"]}
    assert qjulia.params(slice=general)["slice"] != qjulia.params()["slice"]
    assert qjulia.params(slice={"axes": "rmp"})["slice"] == {"axes": "rmp", "fixed": 0.0}


def test_none_removes_a_key_so_its_default_applies():
    p = qjulia.params("quaternion-mandelbrot", start=None)
    assert p["start"] == [0.0, 0.0, 0.0, 0.0]
    assert qjulia.params("quaternion-mandelbrot", start=[0.1, 0, 0, 0])["start"][0] == 0.1
    assert "faces" not in qjulia.params(mesh={"faces": None})["mesh"]


def test_numpy_values_are_accepted():
    c = np.array([-0.2, 0.8, 0.0, 0.0])
    p = qjulia.params("classic-julia", constants={"c": c}, iterations=np.int64(9))
    assert p["constants"]["c"] == c.tolist() and p["iterations"] == 9


def test_a_dict_and_a_file_give_the_same_mesh_parameters(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps(qjulia.params("classic-julia", resolution=20)))
    from_file = qjulia.mesh(path)
    from_dict = qjulia.mesh(qjulia.params("classic-julia"), resolution=20)
    assert from_file.params == from_dict.params
    assert from_file.stats["faces"] == from_dict.stats["faces"] > 0


def test_an_unknown_key_is_a_value_error_naming_it():
    with pytest.raises(ValueError, match="unknown key 'iteratoins'"):
        qjulia.mesh(iteratoins=5)
    with pytest.raises(ValueError, match="unknown key 'mesh.fcaes'"):
        qjulia.params(mesh={"fcaes": 5})


def test_params_and_preset_together_are_a_value_error():
    with pytest.raises(ValueError, match="either"):
        qjulia.mesh({"resolution": 8}, preset="unit-ball")


def test_an_unknown_preset_has_the_cli_message():
    with pytest.raises(ValueError) as e:
        qjulia.params("no-such-preset")
    assert str(e.value) == cli_error("params", "--preset", "no-such-preset")


def test_a_mesh_file_gives_the_parameters_it_records(tmp_path):
    m = qjulia.mesh(preset="classic-julia", resolution=20)
    m.save(tmp_path / "m.glb")
    same = qjulia.mesh(tmp_path / "m.glb")
    assert same.params == m.params
    assert (same.stats["faces"], same.stats["volume"]) == (m.stats["faces"], m.stats["volume"])
    again = qjulia.mesh(str(tmp_path / "m.glb"), resolution=24)
    assert again.params["resolution"] == 24 and again.params["formula"] == m.params["formula"]


def test_a_preset_that_is_not_a_name_is_a_type_error():
    with pytest.raises(TypeError, match="preset must be a preset's name"):
        qjulia.params(preset=5)


def test_a_bad_formula_has_the_cli_message(tmp_path):
    # Named by its source, as the CLI names a parameter file: "parameters" for a dict.
    with pytest.raises(ValueError) as e:
        qjulia.mesh(formula="h^^2", resolution=8)
    assert str(e.value) == "parameters: " + cli_error("params", "--formula", "h^^2")
    assert "formula 1:3" in str(e.value)
    path = tmp_path / "bad.json"
    path.write_text('{"formula": "h^^2"}')
    with pytest.raises(ValueError) as e:
        qjulia.mesh(path)
    assert str(e.value) == cli_error("mesh", path, "-o", tmp_path / "x.ply")


def test_a_bad_parameter_file_has_the_cli_message(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{"formula": "h^2", "itertions": 4}')
    with pytest.raises(ValueError) as e:
        qjulia.mesh(str(path))
    assert str(e.value) == cli_error("mesh", path, "-o", tmp_path / "x.ply")
    assert not (tmp_path / "x.ply").exists()


def test_a_missing_parameter_file_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError) as e:
        qjulia.mesh(tmp_path / "missing.json")
    assert e.value.filename == str(tmp_path / "missing.json")


def test_a_directory_as_parameter_file_is_an_os_error(tmp_path):
    with pytest.raises(OSError):
        qjulia.mesh(tmp_path)


@pytest.mark.parametrize("overrides,key", [
    (dict(bailout=float("nan")), "bailout"),
    (dict(constants={"c": [np.float32("inf"), 0, 0, 0]}), "constants.c[0]"),
    (dict(bounds={"min": [-1, -1, float("-inf")], "max": [1, 1, 1]}), "bounds.min[2]"),
])
def test_a_non_finite_number_is_a_value_error_naming_its_key(overrides, key):
    with pytest.raises(ValueError) as e:
        qjulia.mesh(preset="classic-julia", resolution=8, **overrides)
    assert f"'{key}'" in str(e.value) and "finite" in str(e.value)


def test_a_path_with_a_nul_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="null byte"):
        qjulia.mesh(str(tmp_path / "p.json") + "\0.json")


def test_wrong_types_are_type_errors():
    with pytest.raises(TypeError):
        qjulia.mesh(42)
    with pytest.raises(TypeError):
        qjulia.params(constants={"c": object()})
