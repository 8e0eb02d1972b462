"""flc.gym: FollowingEnv (issue 26): the Gymnasium API, vector envs, determinism, the reward."""
import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import flc  # noqa: E402
import flc.gym as fg  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402


@pytest.mark.parametrize("observation", fg.OBSERVATIONS)
@pytest.mark.parametrize("action", fg.ACTIONS)
def test_check_env_passes(observation: str, action: str) -> None:
    env = gym.make("flc/Following-v0", observation=observation, action=action, beams=16)
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    env.close()


def rollout(env, seed: int, steps: int = 60) -> tuple[list, list, list]:
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    observations, rewards, infos = [obs], [], [info["t"]]
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(env.action_space.sample() * 0 + rng.uniform(-3, 2, size=1).astype(np.float32))
        observations.append(obs)
        rewards.append(r)
        infos.append((info["t"], info["gap"], tuple(info["reward_terms"].values())))
        if term or trunc:
            break
    return observations, rewards, infos


def test_same_seed_same_episode_other_seed_other_scenario() -> None:
    env = fg.FollowingEnv(observation="lidar", beams=32)
    a = rollout(env, 7)
    b = rollout(fg.FollowingEnv(observation="lidar", beams=32), 7)
    for x, y in zip(a[0], b[0]):
        assert np.array_equal(x, y)
    assert a[1] == b[1] and a[2] == b[2]
    names = {env.reset(seed=s)[1]["scenario"] for s in range(12)}
    assert len(names) >= 3, names


def test_vector_envs_sync_and_async() -> None:
    make = lambda: gym.make("flc/Following-v0", observation="kinematics", policy_frequency=5.0)  # noqa: E731
    for cls in (gym.vector.SyncVectorEnv, gym.vector.AsyncVectorEnv):
        envs = cls([make for _ in range(2)])
        obs, _ = envs.reset(seed=[3, 4])
        assert obs.shape == (2, 6)
        total = np.zeros(2)
        for _ in range(20):
            obs, r, term, trunc, _ = envs.step(np.full((2, 1), -0.5, dtype=np.float32))
            total += r
        assert obs.shape == (2, 6) and np.all(np.isfinite(total))
        envs.close()
    # Sync and async give the same numbers for the same seeds.
    sync = gym.vector.SyncVectorEnv([make for _ in range(2)])
    asyn = gym.vector.AsyncVectorEnv([make for _ in range(2)])
    o1, _ = sync.reset(seed=[5, 6])
    o2, _ = asyn.reset(seed=[5, 6])
    assert np.array_equal(o1, o2)
    for _ in range(10):
        a = np.full((2, 1), 0.5, dtype=np.float32)
        s1 = sync.step(a)
        s2 = asyn.step(a)
        assert np.array_equal(s1[0], s2[0]) and np.array_equal(s1[1], s2[1])
    sync.close()
    asyn.close()


def test_reward_terms_against_hand_computed_values_on_a_scripted_episode() -> None:
    # CCRs-like: a standing lead 40 m ahead, the ego at 10 m/s, no sensor noise; the policy
    # coasts (a = 0) until the true gap is below 11 m, then brakes at -8 m/s². Every step's terms are checked against the ground truth
    # the environment reports, computed here by hand from the documented formulas.
    sc = flc.Scenario.paper(36, "flc", lead_initial_speed=0.0, follower_initial_speed=10.0, follower_initial_gap=40.0, lidar_range_noise_std=0.0)
    sc = sc.replace(**{"lead.phases": []})
    w = fg.RewardWeights()
    env = fg.FollowingEnv(sc, policy_frequency=10.0, time_limit=20.0)
    obs, info = env.reset(seed=0)
    assert info["gap"] == pytest.approx(40.0, abs=1e-6)
    prev_accel = info["accel"]
    seen_headway = seen_jerk = False
    brake = False
    for k in range(200):
        brake |= info["gap"] < 11.0
        a = -8.0 if brake else 0.0
        obs, r, term, trunc, info = env.step(np.array([a], dtype=np.float32))
        # A policy step is 0.1 s (two 20 Hz scans); the last one ends where the run ends.
        dt = info["dt"]
        assert dt == pytest.approx(0.1, abs=1e-9) or (term and dt < 0.1)
        gap, v, acc = info["gap"], info["speed"], info["accel"]
        h = gap / max(v, 1.0)
        expected = {
            "collision": -100.0 if info["collision"] else 0.0,
            "headway": -1.0 * max(0.0, 1.0 - h),
            "comfort": -0.001 * ((acc - prev_accel) / dt) ** 2,
            "progress": 1.0 * v * dt / 10.0,
        }
        prev_accel = acc
        for name, value in expected.items():
            assert info["reward_terms"][name] == pytest.approx(value, rel=1e-9, abs=1e-12), (k, name)
        assert r == pytest.approx(sum(expected.values()), rel=1e-9, abs=1e-12)
        seen_headway |= expected["headway"] < 0
        seen_jerk |= expected["comfort"] < -1.0
        if term or trunc:
            break
    assert w.collision == 100.0
    # Braking from ~9.6 m/s at 11 m, the headway falls below 1 s (it costs); the hard braking is
    # a large jerk; the ego stops before the lead: terminated by the standstill end, no collision.
    assert seen_headway and seen_jerk
    assert term and not trunc and not info["collision"]


def test_collision_terminates_with_the_penalty_and_time_limit_truncates() -> None:
    sc = flc.Scenario.paper(36, "flc", lead_initial_speed=0.0, follower_initial_speed=12.0, follower_initial_gap=30.0)
    sc = sc.replace(**{"lead.phases": []})
    env = fg.FollowingEnv(sc, action="speed", time_limit=20.0)
    env.reset(seed=0)
    for _ in range(200):
        _, r, term, trunc, info = env.step(np.array([12.0], dtype=np.float32))
        if term or trunc:
            break
    assert term and not trunc and info["collision"]
    assert info["reward_terms"]["collision"] == -100.0
    far = flc.Scenario.paper(50, "flc", follower_initial_gap=100.0)
    env = fg.FollowingEnv(far, action="speed", time_limit=3.0)
    env.reset(seed=0)
    n = 0
    while True:
        _, _, term, trunc, info = env.step(np.array([5.0], dtype=np.float32))
        n += 1
        if term or trunc:
            break
    assert trunc and not term and n == 30


def test_the_flc_as_a_policy_drives_as_flc_run() -> None:
    sc = flc.Scenario.paper(50, "flc")
    env = fg.FollowingEnv(sc, action="speed", policy_frequency=20.0, time_limit=150.0)
    law = flc.FallbackController(**sc["flc"])
    env.reset(seed=0)
    sim = env.simulation
    o = env._obs
    while True:
        cmd = law.step(o.distance, o.own_speed).speed
        _, _, term, trunc, _ = env.step(np.array([cmd], dtype=np.float32))
        o = env._obs
        if term or trunc:
            break
    r = sim.result()
    ref = flc.run(sc.replace(seed=r.scenario.seed, duration=150.0))
    # float32 actions: the same outcome within float32 rounding of the command.
    assert r.metrics["collision"] == ref.metrics["collision"]
    assert r.metrics["min_gap"] == pytest.approx(ref.metrics["min_gap"], abs=0.05)


def test_bad_arguments_name_the_argument() -> None:
    with pytest.raises(flc.ParameterError, match="observation"):
        fg.FollowingEnv(observation="pixels")
    with pytest.raises(flc.ParameterError, match="policy_frequency"):
        fg.FollowingEnv(policy_frequency=50.0)
    with pytest.raises(flc.ParameterError, match="families"):
        fg.ScenarioSampler(families=("cut-in",))


def test_pettingzoo_platoon_env_passes_the_parallel_api_test() -> None:
    pytest.importorskip("pettingzoo")
    from pettingzoo.test import parallel_api_test

    from flc.marl import PlatoonEnv

    env = PlatoonEnv(flc.Scenario.brakedemo(platoon_followers=3), time_limit=30.0)
    parallel_api_test(env, num_cycles=200)
    obs, _ = env.reset(seed=2)
    assert set(obs) == {"follower_1", "follower_2", "follower_3"}
    # Every agent at -2 m/s² for 1 s: each slows, each reward has the documented terms.
    for _ in range(10):
        obs, rewards, terms, truncs, infos = env.step({a: np.array([-2.0], dtype=np.float32) for a in env.agents})
    for a, info in infos.items():
        assert set(info["reward_terms"]) == {"collision", "headway", "comfort", "progress"}
        assert rewards[a] == pytest.approx(sum(info["reward_terms"].values()))
    speeds = [infos[a]["speed"] for a in ("follower_1", "follower_2", "follower_3")]
    assert all(v < 120 / 3.6 - 1.0 for v in speeds), speeds
