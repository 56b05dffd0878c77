"""WarpRollout against RolloutPool, on warp's default device (the CPU device in CI: no GPU there).

Marked `warp` and skipped without the judo-mpc[warp] extra. Warp compiles its kernels once per
process and caches them on disk; the first run of this module takes about a minute for that, so the
tests are few and share one backend per model.

Tolerance: MuJoCo Warp computes in float32, MuJoCo in float64. Over 5 steps of 10 ms the states and
sensors agree within ATOL = 1e-4 (measured: about 2e-7 without contacts, 1e-5 with the ball's
contact).
"""

import copy
import json
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np
import pytest

pytest.importorskip("warp")
pytest.importorskip("mujoco_warp")

import judo
from judo.core.model import STATE_SPEC
from judo.core.rollouts.backend import RandomizedRolloutError
from judo.core.rollouts.problem_batch import ProblemBatch, ProblemBatchError
from judo.core.rollouts.rollout import RolloutPool
from judo.core.rollouts.warp_models import WarpUnsupportedModelError
from judo.core.rollouts.warp_overflow import RolloutOverflowWarning
from judo.core.rollouts.warp_rollout import WarpRollout

pytestmark = pytest.mark.warp

ATOL = 1e-4
N, T = 4, 5

BALLS_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="cart" pos="0 0 0.5">
      <joint name="slider" type="slide" axis="1 0 0"/>
      <geom type="box" size=".2 .1 .1" mass="1" contype="0" conaffinity="0"/>
      <body name="pole">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.6" size=".04" mass=".1" contype="0" conaffinity="0"/>
        <site name="tip" pos="0 0 0.6"/>
      </body>
    </body>
    <body name="ball" pos="0.5 0 0.099"><freejoint/><geom type="sphere" size="0.1" mass="0.2"/></body>
    <body name="ball2" pos="-0.5 0 0.099"><freejoint/><geom type="sphere" size="0.1" mass="0.2"/></body>
    <body name="goal" mocap="true" pos="0 0 1"><geom size="0.05" contype="0" conaffinity="0"/></body>
  </worldbody>
  <actuator><motor joint="slider" gear="10" ctrlrange="-1 1"/></actuator>
  <sensor>
    <framepos name="trace_tip" objtype="site" objname="tip"/>
    <jointpos name="angle" joint="hinge"/>
    <framepos name="ball_pos" objtype="body" objname="ball"/>
    <framepos name="goal_pos" objtype="body" objname="goal"/>
  </sensor>
</mujoco>
"""  # noqa: E501
"""A cart-pole on a motor, two balls rolling on a floor (contacts) and a mocap goal."""


def start_state(model: mujoco.MjModel) -> np.ndarray:
    """(nstate,) full-physics state: the pole tilted, the cart and both balls moving."""
    data = mujoco.MjData(model)
    data.time = 1.5
    data.qpos[1] = 0.3
    data.qvel[:2] = [0.5, -1.0]
    data.qvel[2:5] = [1.0, 0.5, 0.0]  # the first ball slides and rolls along the floor
    data.qvel[8:11] = [-1.0, 0.0, 0.0]
    state = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    return state


@pytest.fixture(scope="module")
def balls():
    model = mujoco.MjModel.from_xml_string(BALLS_XML)
    backend = WarpRollout(model, deterministic=True)  # the test checks bitwise repeats, on CUDA too
    yield model, backend
    backend.close()


def test_tiny_model_with_contacts_and_mocap_matches_the_cpu_pool_and_repeats_itself(balls):
    model, backend = balls
    initial = start_state(model)
    controls = np.random.default_rng(0).uniform(-1, 1, (N, T, model.nu))
    mocap = np.array([0.3, -0.2, 0.5, 0.0, 0.0, 0.0, 1.0])
    states, sensors = backend.rollout(initial, controls, mocap)
    states, sensors = states.copy(), sensors.copy()
    pool = RolloutPool(model, num_workers=1)
    expected_states, expected_sensors = pool.rollout(initial, controls, mocap)
    pool.close()
    assert states.shape == (N, T, initial.size) and states.dtype == np.float64
    assert sensors.shape == (N, T, model.nsensordata) and sensors.dtype == np.float64
    np.testing.assert_allclose(states, expected_states, atol=ATOL, rtol=0)
    np.testing.assert_allclose(sensors, expected_sensors, atol=ATOL, rtol=0)
    np.testing.assert_allclose(
        sensors[..., -3:], np.broadcast_to([0.3, -0.2, 0.5], (N, T, 3)), atol=1e-6
    )
    # the ball, untouched by the controls, agrees: exactly on the CPU device; on CUDA world 0 was
    # seen one float32 ulp (6e-8) off the others on an H100
    assert np.ptp(states[:, -1, 1 + model.nq + 2]) <= (1e-6 if backend.device.is_cuda else 0.0)
    assert np.ptp(states[:, -1, 1]) > 1e-3  # the carts, driven differently, do not

    # nothing carries over between calls
    again, again_sensors = backend.rollout(initial, controls, mocap)
    np.testing.assert_array_equal(again, states)
    np.testing.assert_array_equal(again_sensors, sensors)
    # no mocap given: the model's own goal pose
    _, default_goal = backend.rollout(initial, controls)
    np.testing.assert_allclose(
        default_goal[..., -3:], np.broadcast_to([0.0, 0.0, 1.0], (N, T, 3)), atol=1e-6
    )


def test_overflowing_contact_and_constraint_buffers_grow_instead_of_dropping_contacts():
    model = mujoco.MjModel.from_xml_string(BALLS_XML)
    initial = start_state(model)
    controls = np.zeros((N, T, model.nu))
    # two ball contacts need 2 contacts and 8 rows per world
    with (
        WarpRollout(model, nconmax=1, njmax=2) as backend,
        RolloutPool(model, num_workers=1) as pool,
    ):
        with pytest.warns(RolloutOverflowWarning) as caught:
            states, _ = backend.rollout(initial, controls)
        messages = [str(w.message) for w in caught]
        assert messages[0].startswith(
            "MuJoCo Warp rollouts overflowed (NEFC, BROADPHASE) in 4 of 4 worlds"
        )
        assert "contacts per world 1 -> 2, constraint rows 2 -> 4; rolled out again" in messages[0]
        assert backend.nconmax >= 2 and backend.njmax >= 8
        np.testing.assert_allclose(states, pool.rollout(initial, controls)[0], atol=ATOL, rtol=0)
    # the with freed the buffers
    assert not hasattr(backend, "_data") and not hasattr(backend, "_host_states")


def test_a_feature_mujoco_warp_lacks_is_named_with_the_cpu_backend_suggested():
    spec = mujoco.MjSpec.from_string(BALLS_XML)
    # MuJoCo 4's PID actuator, not in MuJoCo Warp 4.0
    spec.actuators[0].dyntype = mujoco.mjtDyn.mjDYN_PID
    spec.actuators[0].gaintype = mujoco.mjtGain.mjGAIN_PID
    spec.actuators[0].biastype = mujoco.mjtBias.mjBIAS_AFFINE
    with pytest.raises(
        WarpUnsupportedModelError,
        match=r"cannot run this model: "
        r"\['mjDYN_PID'\] not supported",
    ) as err:
        WarpRollout(spec.compile())
    assert "--backend cpu" in str(err.value)


def cartpole_on_warp() -> judo.Controller:
    """Seeded predictive sampling on cartpole with a 0.5 s horizon (50 steps): warp's CPU device
    launches every kernel of every step one after the other, so short horizons keep the test
    fast."""
    controller = judo.make_controller(
        "cartpole",
        "ps",
        seed=0,
        backend="warp",
        controller_config=judo.ControllerConfig(horizon=0.5),
    )
    # a bitwise repeat on CUDA needs warp's deterministic launches
    if controller.backend.device.is_cuda:
        controller.backend.close()
        controller.backend = WarpRollout(controller.task.model, deterministic=True)
    return controller


@pytest.fixture(scope="module")
def cartpole_warp():
    controller = cartpole_on_warp()
    yield controller
    controller.close()


def test_cartpole_matches_the_cpu_pool(cartpole_warp):
    model = cartpole_warp.task.model
    data = mujoco.MjData(model)
    data.qpos[:] = [0.1, np.pi - 0.2]
    initial = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, initial, STATE_SPEC)
    controls = np.random.default_rng(1).uniform(-1, 1, (N, T, model.nu))
    states, sensors = cartpole_warp.backend.rollout(initial, controls)
    pool = RolloutPool(model, num_workers=1)
    expected_states, expected_sensors = pool.rollout(initial, controls)
    pool.close()
    np.testing.assert_allclose(states, expected_states, atol=ATOL, rtol=0)
    np.testing.assert_allclose(sensors, expected_sensors, atol=ATOL, rtol=0)


def test_the_controller_improves_cartpole_on_warp_and_a_seeded_run_repeats_itself(cartpole_warp):
    state = np.array([0.0, 1.0, 0.0, 0.0])  # the pole 1 rad from upright

    def best_rewards(controller: judo.Controller) -> list[float]:
        best = []
        for _ in range(6):
            controller.update_action(state, 0.0)
            best.append(float(controller.rewards.max()))
        return best

    first = best_rewards(cartpole_warp)
    # same start state: later plans roll out better (cpu: -660 -> -616)
    assert first[-1] > first[0] + 10.0
    # ps keeps its best
    assert all(b2 >= b1 - 1e-9 for b1, b2 in zip(first, first[1:], strict=False))
    assert cartpole_warp.backend_name == "warp" and isinstance(cartpole_warp.backend, WarpRollout)
    with cartpole_on_warp() as again:
        assert best_rewards(again) == first
        np.testing.assert_array_equal(again.nominal_knots, cartpole_warp.nominal_knots)
    assert not hasattr(again.backend, "_data")  # leaving the with closed the controller's backend


def perturbed(model: mujoco.MjModel, mass: float, friction: float) -> mujoco.MjModel:
    """A copy of `model` with the first ball `mass` times heavier, every friction `friction` and the
    slider damped, its derived constants recomputed (as `randomized_models` does)."""
    other = copy.deepcopy(model)
    other.body_mass[other.body("ball").id] *= mass
    other.geom_friction[:, 0] = friction
    other.dof_damping[0] = 0.5
    mujoco.mj_setConst(other, mujoco.MjData(other))
    return other


def test_randomized_models_run_per_world_and_a_redraw_keeps_the_device_model_and_graph(balls):
    model, _ = balls
    initial = start_state(model)
    controls = np.random.default_rng(2).uniform(-1, 1, (2 * N, T, model.nu))
    models = [model, perturbed(model, 3.0, 0.3)]
    with (
        WarpRollout(model, deterministic=True) as backend,
        RolloutPool(model, num_workers=1) as pool,
    ):
        backend.set_models(models)
        states = backend.rollout(initial, controls)[0].copy()
        pool.set_models(models)
        np.testing.assert_allclose(states, pool.rollout(initial, controls)[0], atol=ATOL, rtol=0)
        tol = 1e-5 if backend.device.is_cuda else 0.0  # bitwise on the CPU device
        for r, each in enumerate(models):  # block r ran on models[r]: as each model alone
            with WarpRollout(each, deterministic=True) as alone:
                block = slice(r * N, (r + 1) * N)
                np.testing.assert_allclose(
                    states[block], alone.rollout(initial, controls[block])[0], atol=tol, rtol=0
                )
        # the heavier, slipperier world moves otherwise
        assert np.abs(states[:N] - states[N:]).max() > 1e-3
        device_model, graph = backend._device_model, backend._graph
        redrawn = [model, perturbed(model, 1.5, 0.6)]  # a redraw: other values in the same fields
        backend.set_models(redrawn)
        again = backend.rollout(initial, controls)[0]
        # written in place, not recaptured
        assert backend._device_model is device_model and backend._graph is graph
        pool.set_models(redrawn)
        np.testing.assert_allclose(again, pool.rollout(initial, controls)[0], atol=ATOL, rtol=0)
        backend.set_models(None)  # back to one model for every row
        one = backend.rollout(initial, controls[:N])[0]
        pool.set_models(None)
        np.testing.assert_allclose(one, pool.rollout(initial, controls[:N])[0], atol=ATOL, rtol=0)


def test_models_that_differ_in_a_field_mujoco_warp_holds_once_are_refused_by_name(balls):
    model, backend = balls
    other = copy.deepcopy(model)
    other.opt.timestep = 0.02
    with pytest.raises(
        RandomizedRolloutError,
        match=r"differ in opt.timestep, which "
        r"MuJoCo Warp .* holds once",
    ):
        backend.set_models([model, other])
    backend.set_models([model, perturbed(model, 2.0, 0.5)])
    with pytest.raises(
        RandomizedRolloutError,
        match="a batch of 5 rollouts cannot be split evenly over the 2 models",
    ):
        backend.rollout(start_state(model), np.zeros((5, T, model.nu)))
    backend.set_models(None)


def test_problems_roll_out_as_one_batch_from_their_own_states_and_slots_wait_for_each_other(balls):
    model, _ = balls
    first = start_state(model)
    second = first.copy()
    second[1:3] = [-0.4, 0.7]  # another cart position and pole angle
    controls = np.random.default_rng(3).uniform(-1, 1, (2 * N, T, model.nu))
    goals = np.array([[0.3, -0.2, 0.5, 1, 0, 0, 0], [0.0, 0.4, 0.2, 1, 0, 0, 0]], dtype=float)
    with WarpRollout(model, deterministic=True) as backend:
        both, sensors = (
            a.copy() for a in backend.rollout_problems(np.stack([first, second]), controls, goals)
        )
        tol = 1e-5 if backend.device.is_cuda else 0.0
        for p, state in enumerate([first, second]):
            rows = slice(p * N, (p + 1) * N)
            alone, alone_sensors = backend.rollout(state, controls[rows], goals[p])
            np.testing.assert_allclose(both[rows], alone, atol=tol, rtol=0)
            np.testing.assert_allclose(sensors[rows], alone_sensors, atol=tol, rtol=0)
        batch = ProblemBatch(backend, 2)
        # each slot's rollout returns once both handed theirs in
        with ThreadPoolExecutor(2) as threads:
            futures = [
                threads.submit(
                    lambda p, s: batch.slots[p].rollout(s, controls[p * N : (p + 1) * N], goals[p]),
                    p,
                    s,
                )
                for p, s in enumerate([first, second])
            ]
            results = [future.result(timeout=300)[0].copy() for future in futures]
        assert batch.launches == 1
        np.testing.assert_array_equal(np.concatenate(results), both)
        batch.slots[1].close()  # slot 1's episode ended: slot 0 rolls out alone, without waiting
        alone = batch.slots[0].rollout(first, controls[:N], goals[0])[0]
        np.testing.assert_allclose(alone, both[:N], atol=tol, rtol=0)
        with pytest.raises(ProblemBatchError, match="cannot roll out under 2 randomized models"):
            batch.slots[0].set_models([model, perturbed(model, 2.0, 0.5)])


@pytest.mark.slow
def test_evaluate_with_episodes_batched_on_warp_gives_the_episodes_run_one_by_one(tmp_path, capsys):
    from judo.evaluation.evaluate import main

    common = [
        "--task",
        "cartpole",
        "--optimizer",
        "ps",
        "--backend",
        "warp",
        "--seeds",
        "2",
        "--duration",
        "0.1",
    ]
    common += ["--controller.horizon", "0.3"]
    assert main([*common, "--json", str(tmp_path / "one.json")]) == 0
    assert main([*common, "--episodes-per-batch", "2", "--json", str(tmp_path / "two.json")]) == 0
    one, two = (json.loads((tmp_path / name).read_text()) for name in ("one.json", "two.json"))
    assert [e["seed"] for e in two["episodes"]] == [0, 1]
    assert (
        [e["num_updates"] for e in two["episodes"]]
        == [e["num_updates"] for e in one["episodes"]]
        != [0, 0]
    )
    # bitwise on the CPU device
    if not WarpRollout(mujoco.MjModel.from_xml_string(BALLS_XML)).device.is_cuda:
        assert [e["metrics"] for e in two["episodes"]] == [e["metrics"] for e in one["episodes"]]
    with pytest.raises(SystemExit) as err:
        main(["--task", "cartpole", "--optimizer", "ps", "--episodes-per-batch", "2"])
    assert err.value.code == 2
    assert "expected --backend warp" in capsys.readouterr().err


def test_collect_with_episodes_batched_on_warp_records_the_episodes_run_one_by_one():
    from judo.collection.episode import collect_episode, collect_group
    from judo.evaluation.seeded import EpisodeSpec

    spec = EpisodeSpec("cartpole", "ps", 0.06, values={"controller.horizon": 0.2}, backend="warp")
    batched = collect_group(spec, [3, 4])
    assert [outcome.seed for outcome in batched] == [3, 4] and all(
        o.failure is None for o in batched
    )
    alone = [collect_episode(spec, seed) for seed in (3, 4)]
    for group, single in zip(batched, alone, strict=True):
        assert group.episode is not None and single.episode is not None
        assert len(group.episode.plan["knots"]) == len(single.episode.plan["knots"]) > 0
        # bitwise on warp's CPU device
        if not WarpRollout(mujoco.MjModel.from_xml_string(BALLS_XML)).device.is_cuda:
            np.testing.assert_array_equal(group.episode.plan["knots"], single.episode.plan["knots"])
            np.testing.assert_array_equal(group.episode.qpos, single.episode.qpos)
    broken = EpisodeSpec(
        "cartpole", "ps", 0.06, values={"controller.num_randomizations": 2}, backend="warp"
    )
    failures = collect_group(broken, [5, 6])  # each seed fails with the reason; nothing raises
    assert [o.seed for o in failures] == [5, 6]
    assert all(
        o.episode is None and "cannot roll out under 2 randomized models" in (o.failure or "")
        for o in failures
    )
