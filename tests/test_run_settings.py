"""Run settings are written once: RunConfig's fields are the command line's options and the API's keywords, with
one set of defaults (issue 49 item 1)."""

from __future__ import annotations

from dataclasses import fields

import pytest
import typer.main

from simtune import api
from simtune.cli import app
from simtune.cli.run_options import API_ONLY, cli_default, setting_options
from simtune.errors import ConfigError
from simtune.run_config import COMPARE_DEFAULTS, TRANSFER_DEFAULTS, RunConfig

#: options of the commands that are not run settings (where a command writes, what it prints)
NOT_SETTINGS = {"out_dir", "quiet", "as_json"}


def _params(name: str) -> dict:
    command = typer.main.get_command(app).commands[name]  # type: ignore[attr-defined]
    return {p.name: p for p in command.params}


def test_every_run_setting_is_a_tune_option_with_runconfigs_default():
    options = _params("tune")
    settings = {f.name for f in fields(RunConfig)}
    assert set(options) - NOT_SETTINGS == settings - set(API_ONLY)
    for name in settings - set(API_ONLY):
        assert options[name].default == cli_default(name), name


def test_the_studies_take_runconfigs_defaults_but_their_declared_own():
    # grid's own --tasks (experiments), --repeats (seeds) and --workers (optimisations at once) are not run settings
    grid = ("data", "max_generations", "only", "keep_inactive", "reference")
    for command, own, names in (
        ("transfer", TRANSFER_DEFAULTS, setting_options()),
        ("compare", COMPARE_DEFAULTS, setting_options()),
        ("grid", {}, grid),
    ):
        for name, param in _params(command).items():
            if name in names:
                assert param.default == own.get(name, cli_default(name)), (command, name)


def test_runconfig_and_the_api_agree_on_every_default():
    made = api.run_config()
    plain = RunConfig()
    for f in fields(RunConfig):
        if f.name not in ("data", "project"):  # the API resolves these against the project
            assert getattr(made, f.name) == getattr(plain, f.name), f.name
    assert made.optimizer == "auto" and made.space == "calibrated" and made.eval_timeout == 600.0
    exact = api.run_config(paper_exact=True, workers=1)
    assert (exact.optimizer, exact.space, exact.reference, exact.targets) == ("de", "shared", "mean", "published")


def test_the_api_takes_every_setting_by_runconfigs_name():
    config = api.run_config(
        "mujoco", "cube", seed=4, prune=False, keep_inactive=True, max_evaluations=7, residuals="plain", threads=True
    )
    assert (config.seed, config.prune, config.keep_inactive, config.max_evaluations) == (4, False, True, 7)
    assert (config.residuals, config.threads) == ("plain", True)
    assert api.run_config(optimizer=None).optimizer == "auto"  # None: the default, as the command line passes it


@pytest.mark.parametrize("settings", [{"sed": 1}, {"max_evals": 5}, {"engine_name": "mujoco"}])
def test_an_unknown_setting_is_one_line_naming_it(settings):
    with pytest.raises(ConfigError, match=f"unknown run setting '{next(iter(settings))}'"):
        api.run_config(**settings)


def test_a_setting_of_the_wrong_type_is_named():
    with pytest.raises(ConfigError, match="seed must be an integer"):
        api.run_config(seed="3")


def test_compare_refuses_what_each_of_its_runs_sets(tmp_path):
    with pytest.raises(ConfigError, match="compare sets optimizer"):
        api.compare(out=tmp_path, optimizer="de")


def test_stored_configurations_keep_what_a_missing_key_meant():
    stored = RunConfig(space="shared", optimizer="de").record()
    del stored["optimizer"], stored["eval_timeout"]
    old = RunConfig.from_stored(stored, "run.sqlite")
    assert (old.optimizer, old.eval_timeout) == ("de", None)
    with pytest.raises(ConfigError, match="has no 'space'"):
        RunConfig.from_stored({k: v for k, v in stored.items() if k != "space"}, "run.sqlite")


def test_no_prune_switches_pruning_off():
    prune = _params("tune")["prune"]
    assert prune.secondary_opts == ["--no-prune"] and prune.default is True  # type: ignore[attr-defined]


def test_every_public_function_of_the_api_documents_its_args_and_returns():
    import inspect

    for name, function in inspect.getmembers(api, inspect.isfunction):
        if name.startswith("_") or function.__module__ != api.__name__:
            continue
        doc = inspect.getdoc(function) or ""
        assert "Returns:" in doc, name
        if inspect.signature(function).parameters:
            assert "Args:" in doc, name
