"""The [safety] section's load checks: one-line errors naming what is wrong and the valid
choices."""

import pytest

from judo.core.configuration.config import with_updates
from judo.core.configuration.config_file import load_config
from judo.core.configuration.config_file_text import ConfigFileError
from judo.core.configuration.registry import make_config, make_task
from judo.core.errors import ConfigError
from judo.safety.config import SafetyConfig
from judo.safety.limits import LimitError, resolve


def test_the_default_is_off():
    assert not SafetyConfig().active
    assert not make_config(SafetyConfig, "cartpole").active  # no shipped task TOML sets limits


@pytest.mark.parametrize(
    ("updates", "message"),
    [
        (
            {"position": ["slider=1:-1"]},
            "SafetyConfig.position slider: the minimum 1 is above the maximum -1",
        ),
        (
            {"position": ["slider=1"]},
            "SafetyConfig.position entry 'slider=1' is not \"JOINT=LOW:HIGH\" with finite numbers",
        ),
        ({"effort": ["push=-2"]}, "SafetyConfig.effort push: the cap must be at least 0, got -2"),
        (
            {"rate": ["push=fast"]},
            "SafetyConfig.rate entry 'push=fast' is not \"NAME=MAX\" with a finite number",
        ),
        ({"velocity": ["hinge=1", "hinge=2"]}, "SafetyConfig.velocity names 'hinge' twice"),
        ({"range_margin": -0.1}, "SafetyConfig.range_margin must be at least 0, got -0.1"),
        (
            {"max_contact_force": -1.0},
            "SafetyConfig.max_contact_force must be a cap of at least 0 N, got -1.0",
        ),
        (
            {"contact_geoms": ["pole"]},
            "SafetyConfig: contact_geoms ['pole'] and max_contact_force 0 go together",
        ),
        (
            {"workspace_frame": "tip", "workspace_low": [1, 0, 0], "workspace_high": [0, 1, 1]},
            "SafetyConfig: workspace_low [1.0, 0.0, 0.0] is above workspace_high "
            "[0.0, 1.0, 1.0] in x",
        ),
        (
            {"workspace_frame": "tip", "workspace_low": [0, 0]},
            "SafetyConfig.workspace_low expects 3 finite numbers",
        ),
    ],
)
def test_nonsense_is_refused_in_one_line(updates, message):
    with pytest.raises(ConfigError) as err:
        with_updates(SafetyConfig(), updates)
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("updates", "message"),
    [
        (
            {"position": ["slidr=-1:1"]},
            "unknown hinge or slide joint 'slidr'; valid hinge or slide joints are: slider, hinge",
        ),
        ({"effort": ["pusher=1"]}, "unknown actuator 'pusher'; valid actuators are: push"),
        (
            {"contact_geoms": ["nope"], "max_contact_force": 5.0},
            "unknown geom 'nope'; valid geoms are: ",
        ),
        (
            {"workspace_frame": "cart", "workspace_low": [0, 0, 0], "workspace_high": [1, 1, 1]},
            "workspace_frame 'cart' is neither the base nor a site or body a "
            "framepos sensor reports; valid frames are: tip",
        ),
        (
            {"joint_ranges": True, "range_margin": 3.0},
            "range_margin 3 is more than half of joint slider's range [-2.0, 2.0]",
        ),
    ],
)
def test_names_the_model_lacks_are_refused_listing_the_valid_ones(updates, message):
    with pytest.raises(LimitError) as err:
        resolve(make_task("cartpole"), with_updates(SafetyConfig(), updates))
    assert message in str(err.value) and "\n" not in str(err.value)


def test_joint_ranges_take_the_mjcf_range_with_the_margin_and_an_entry_wins():
    limits = resolve(make_task("cartpole"), SafetyConfig(joint_ranges=True, range_margin=0.25))
    assert (
        limits.position == ["slider"]
        and list(limits.position_low) == [-1.75]
        and list(limits.position_high) == [1.75]
    )
    limits = resolve(
        make_task("cartpole"), SafetyConfig(joint_ranges=True, position=("slider=-1:0.5",))
    )
    assert list(limits.position_low) == [-1.0] and list(limits.position_high) == [0.5]


def test_a_position_actuators_pd_torque_is_its_effort():
    """quadruped's position actuators: force = kp (q_des - q) - kv dq, from gainprm and biasprm."""
    task = make_task("quadruped")
    model = task.model
    limits = resolve(task, SafetyConfig(effort=("*=5",)))
    assert len(limits.effort) == model.nu
    i = 0
    q_des, q, dq = 0.3, 0.1, -0.2
    kp, kv = model.actuator_gainprm[i, 0], -model.actuator_biasprm[i, 2]
    qpos, qvel = model.qpos0.copy(), [0.0] * model.nv
    import numpy as np

    qpos, qvel = np.array(qpos), np.array(qvel, dtype=float)
    qpos[limits.effort_qpos[i]], qvel[limits.effort_qvel[i]] = q, dq
    ctrl = np.zeros(model.nu)
    ctrl[i] = q_des
    force = limits.effort_of(ctrl, qpos, qvel)[i]
    assert force == pytest.approx(kp * (q_des - q) - kv * dq)


def test_a_config_file_section_is_checked_at_load(tmp_path):
    path = tmp_path / "limits.toml"
    path.write_text('[safety.cartpole]\nvelocity = ["hinje=3"]\n')
    with pytest.raises(ConfigFileError) as err:
        load_config(path)
    assert str(err.value) == (
        f"{path}: [safety.cartpole]: safety limits: unknown hinge or slide joint 'hinje'; "
        "valid hinge or slide joints are: slider, hinge"
    )
    path.write_text('[safety.nosuchtask]\nvelocity = ["hinge=3"]\n')
    with pytest.raises(ConfigFileError, match=r"\[safety.nosuchtask\]: unknown task 'nosuchtask'"):
        load_config(path)


def test_a_config_files_section_reaches_evaluates_episodes(tmp_path, monkeypatch):
    import judo.core.configuration.registry as registry
    from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode

    # the file's defaults end with the test
    monkeypatch.setattr(registry, "_OVERRIDES", dict(registry._OVERRIDES))
    path = tmp_path / "limits.toml"
    path.write_text('[safety.cartpole]\nposition = ["slider=-0.05:0.05"]\n')
    result = run_seeded_episode(EpisodeSpec("cartpole", "ps", 0.1, config_file=str(path)), seed=0)
    # the random start lies beyond 5 cm
    assert "limit_hits" in result.metrics and result.no_feasible > 0
