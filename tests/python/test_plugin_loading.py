"""Only the plugin libraries an experiment or a System names are mapped (issue 37): a library planted in a plugin
folder beside the plugin used, whose constructor writes the file GEOBARRIER_TEST_MARKER names
(tests/plugins/planted.c), never runs from validate, run or System; plugins(), which lists everything, maps it."""

import shutil

import geobarrier
from conftest import TEST_PLUGIN_DIR, base_experiment


def planted_folder(tmp_path, monkeypatch):
    folder = tmp_path / "plugins"
    folder.mkdir()
    shutil.copy(TEST_PLUGIN_DIR / "geobarrier-rigid-rotation.so", folder)
    shutil.copy(TEST_PLUGIN_DIR / "planted" / "geobarrier-planted.so", folder)
    marker = tmp_path / "marker"
    monkeypatch.setenv("GEOBARRIER_TEST_MARKER", str(marker))
    return folder, marker


def test_a_planted_library_is_not_mapped_by_validate_run_or_system(tmp_path, monkeypatch):
    folder, marker = planted_folder(tmp_path, monkeypatch)
    experiment = base_experiment(system={"plugin": "rigid-rotation"}, forcing={"plugin": "none"},
                                 plugin_paths=[str(folder)])
    geobarrier.validate(experiment)
    assert not marker.exists()
    geobarrier.run(experiment)
    assert not marker.exists()
    geobarrier.System("rigid-rotation", plugin_paths=[folder])
    assert not marker.exists()
    geobarrier.plugins([folder])  # listing maps every library of the folder: the marker proves the check is real
    assert marker.exists()
