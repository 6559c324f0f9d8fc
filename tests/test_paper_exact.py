"""--paper-exact: differential evolution step for step as SciPy runs it with the seed paper's settings."""

import subprocess
import sys

import numpy as np
import pytest
from scipy.optimize import differential_evolution

from simtune.errors import ConfigError
from simtune.run_plan import plan_run
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore

#: the seed paper's settings, spelled out here rather than imported: SciPy's defaults except the
#: population size (1 x D) and tolerance, as the paper states them
PAPER = dict(
    strategy="best1bin",
    recombination=0.7,
    mutation=(0.5, 1.0),
    popsize=1,
    init="latinhypercube",
    tol=0.01,
    updating="immediate",
    polish=True,
)


@pytest.fixture(scope="module")
def single_data(tmp_path_factory):
    """Synthetic recordings of the `single` task (6 s, no object): the cheapest objective."""
    from simtune.data import write_qualisys_tsv
    from simtune.reference.make import synthesize
    from simtune.tasks import get_task

    root = tmp_path_factory.mktemp("data")
    (root / "single").mkdir()
    for rec in synthesize("mujoco", get_task("single"), {}, repeats=2, noise_m=0.002, jitter_s=0.0, seed=3):
        write_qualisys_tsv(root / "single" / rec.source.name, rec, header=True)
    return root


@pytest.mark.slow  # about 40 s: SciPy's polish of 31 parameters takes some 2600 evaluations
def test_paper_exact_is_scipys_own_run(single_data, tmp_path):
    """Same seed, same objective: every generation's population and fitness, and the polished end point,
    equal SciPy's when it is called directly with the paper's settings."""
    config = RunConfig(
        optimizer="de",
        engine="mujoco",
        tasks="single",
        space="shared",
        data=str(single_data),
        seed=7,
        max_generations=2,
        paper_exact=True,
    )
    result = start_run(config, tmp_path / "run", show_progress=False)

    objective = plan_run(config).objective()
    assert len(objective.vector_space()) == 31  # the paper's whole shared list, object masses included
    direct = []
    scipy_result = differential_evolution(
        lambda x: objective.score_vector(x).fitness,
        bounds=objective.vector_space().bounds,
        maxiter=2,
        rng=np.random.default_rng(7),
        callback=lambda intermediate_result: direct.append(
            (intermediate_result.population.copy(), intermediate_result.population_energies.copy())
        ),
        **PAPER,
    )
    store = RunStore(tmp_path / "run")
    # every generation is recorded; the store keeps the latest population alone (what --rescore starts from)
    assert [g["best_fitness"] for g in store.generations()] == [float(np.min(e)) for _, e in direct]
    assert len(direct) == 2 and store.last_checkpoint(up_to=1) is None
    checkpoint = store.last_checkpoint()
    assert checkpoint["generation"] == 2
    np.testing.assert_array_equal(checkpoint["population"], direct[-1][0])
    np.testing.assert_array_equal(checkpoint["energies"], direct[-1][1])
    # the polish ran through the store: simtune asked for as many evaluations as SciPy made (repeated
    # points, which L-BFGS-B asks for, are taken from the store)
    assert result.used_evaluations == scipy_result.nfev > store.count_evaluations() > 3 * 31
    assert result.fitness == scipy_result.fun
    np.testing.assert_array_equal(result.x, scipy_result.x)
    assert store.get("config")["paper_exact"] is True
    assert store.get("de_settings")["updating"] == "immediate" and store.get("de_settings")["polish"] is True
    assert "restitution_floor" not in store.get("parameters")  # shared space: no restitution
    assert set(store.get("unmapped_parameters")) <= set(store.get("parameters"))
    store.close()

    # the report says how the run searched: in its header and in Table III
    import csv

    from simtune.report import make_report

    index = make_report(tmp_path / "run", tmp_path / "report", show_progress=False)
    assert "1 of 1 runs searched exactly as the paper ran SciPy" in index.read_text()
    rows = list(csv.DictReader((tmp_path / "report" / "tables" / "paper_table_iii.csv").read_text().splitlines()))
    assert rows[0]["search"] == "de, paper-exact" and rows[0]["D"] == "31" and rows[0]["population"] == "31"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"workers": 2}, "drop --workers"),
        ({"only": ["timestep"]}, "drop --only"),
        ({"space": "extended"}, "paper's spaces"),
        ({"optimizer": "cmaes"}, "differential evolution"),
        ({"refine": True}, "drop --refine"),
    ],
)
def test_paper_exact_refuses_what_the_paper_did_not_do(change, message):
    settings = {"engine": "mujoco", "tasks": "cube", "space": "shared", "data": ".", "paper_exact": True}
    config = RunConfig(**{**settings, **change})
    with pytest.raises(ConfigError, match=message):
        config.check()


@pytest.mark.slow  # 24 s: a paper-exact search over the full D
def test_paper_exact_keeps_parameters_the_engine_lacks(single_data):
    """The individual space in Drake: 57 parameters in the vector, though Drake maps far fewer of them."""
    pytest.importorskip("pydrake")
    config = RunConfig(
        optimizer="de", engine="drake", tasks="single", space="individual", data=str(single_data), paper_exact=True
    )
    assert len(plan_run(config).objective().vector_space()) == 57
    config.paper_exact = False
    assert len(plan_run(config).objective().vector_space()) < 57


def test_cli_paper_exact_refuses_workers(single_data, tmp_path):
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "simtune.cli",
            "tune",
            "--task",
            "single",
            "--data",
            str(single_data),
            "--space",
            "shared",
            "--paper-exact",
            "--workers",
            "2",
            "--out",
            str(tmp_path / "r"),
            "--json",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith("error:") and "--workers" in proc.stderr
    assert not (tmp_path / "r").exists()
