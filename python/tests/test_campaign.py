"""pmon.campaign: the same results file, byte for byte, in-process and on Dask (2 workers, and with a worker
killed mid-campaign); merging is order-free; tasks are seeded by identity; a bad task is reported."""

import json
import os
import random
import signal
from collections import Counter

import pytest

from pmon import campaign

FAULTS = [
    {"kind": "none"},
    {"kind": "permanent_position", "magnitude_m": 1.0, "direction": "away"},
    {"kind": "random_position", "magnitude_m": 1.5, "rate": 0.2, "direction": "random"},
    {"kind": "transient_speed", "magnitude_mps": 3.0, "rate": 0.2},
]


def small_plan(duration_s=1.0):
    # 2 scenes x 2 seeds x 4 faults = 16 tasks; position noise so that the injection seed matters everywhere.
    return campaign.plan(
        ["pedestrians", "intersection"],
        scene_seeds=[3, 4],
        faults=FAULTS,
        duration_s=duration_s,
        position_noise_m=0.1,
        seed=11,
    )


@pytest.fixture(scope="module")
def local_result():
    return campaign.run(small_plan())


def flat(metrics, prefix=""):
    out = {}
    for k, v in metrics.items():
        if isinstance(v, dict):
            out.update(flat(v, prefix + k + "."))
        else:
            out[prefix + k] = v
    return out


def test_local_run_has_every_task_and_totals_are_the_sums(local_result):
    content = json.loads(local_result.to_json())
    assert content["failed"] == []
    assert len(content["tasks"]) == 16
    ids = [t["id"] for t in content["tasks"]]
    assert ids == sorted(ids) and len(set(ids)) == 16
    # An independent sum (flattened keys, collections.Counter) of the per-task counts.
    total = Counter()
    for t in content["tasks"]:
        total.update(flat(t["metrics"]))
    assert flat(content["total"]) == dict(total)
    assert content["total"]["sensor"]["injected"] > 0 and content["total"]["sensor"]["detected"] > 0
    assert sum(s["tasks"] for s in content["settings"]) == 16 and len(content["settings"]) == 4


def test_merge_does_not_depend_on_the_order(local_result):
    rows = [{"id": t["id"], "task": t["task"], "metrics": t["metrics"]} for t in local_result.content["tasks"]]
    for seed in range(5):
        shuffled = rows[:]
        random.Random(seed).shuffle(shuffled)
        assert campaign.merge(shuffled) == local_result.content
    with pytest.raises(ValueError, match="reported twice"):
        campaign.merge(rows + rows[:1])


def test_tasks_are_seeded_by_identity_not_by_order(local_result):
    sub = campaign.plan(["intersection"], scene_seeds=[4], faults=FAULTS[2:3], duration_s=1.0,
                        position_noise_m=0.1, seed=11)
    assert len(sub) == 1
    alone = campaign.run_task(sub[0])
    in_campaign = {t["id"]: t["metrics"] for t in local_result.content["tasks"]}
    assert alone["metrics"] == in_campaign[alone["id"]]
    # Another campaign seed gives other injection seeds and (with noise on every object) other counts.
    other = campaign.plan(["intersection"], scene_seeds=[4], faults=FAULTS[2:3], duration_s=1.0,
                          position_noise_m=0.1, seed=12)
    assert other[0]["injection_seed"] != sub[0]["injection_seed"]
    assert campaign.run_task(other[0])["metrics"] != alone["metrics"]


def test_a_bad_task_is_reported_not_dropped():
    tasks = campaign.plan(["pedestrians", "no_such_scene"], faults=FAULTS[:1], duration_s=0.5)
    r = campaign.run(tasks)
    assert len(r.content["tasks"]) == 1
    assert len(r.failed) == 1 and "no_such_scene" in r.failed[0]["error"]
    bad = dict(tasks[0], surprise=1)
    assert "unknown field `surprise`" in campaign.run_task(bad)["error"]
    with pytest.raises(ValueError, match="cell_size_m"):
        campaign.plan(["pedestrians"], faults=FAULTS[:1], params=[{"cell_size_m": -1.0}])


def test_a_worker_keeps_the_last_eight_scenes():
    """The scene cache of a worker process is bounded: after tasks on 10 scenes it holds the 8 used last."""
    from pmon._pmon import _cached_scenes

    tasks = campaign.plan(["pedestrians"], scene_seeds=list(range(100, 110)), faults=FAULTS[:1], duration_s=0.3,
                          seed=2)
    assert len(tasks) == 10
    for t in tasks:
        campaign.run_task(t)
    again = campaign.run_task(tasks[-1])  # a kept scene: served from the cache, the same counts
    assert again["metrics"] == campaign.run_task(tasks[-1])["metrics"]
    kept = [k for k in _cached_scenes() if k[2] == 0.3]
    assert len(_cached_scenes()) == 8 and len(kept) == 8
    assert {k[1] for k in kept} == {t["scene_seed"] for t in tasks[2:]}
    assert kept[-1][1] == tasks[-1]["scene_seed"], "the one used last is the most recent"


def test_the_results_file_is_never_overwritten(tmp_path, local_result):
    out = tmp_path / "results.json"
    local_result.write(out)
    assert out.read_text() == local_result.to_json()
    with pytest.raises(FileExistsError):
        local_result.write(out)


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("dask.distributed", reason="dask[distributed] is not installed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl:
        with distributed.Client(cl) as client:
            yield client


def test_dask_two_workers_give_the_same_bytes(dask_client, local_result):
    r = campaign.run(small_plan(), dask_client)
    assert r.engine == "dask" and r.workers == 2
    assert r.to_json() == local_result.to_json()
    print(f"\nlocal {local_result.wall_s:.2f} s, dask 2 workers {r.wall_s:.2f} s, pids {r.worker_pids}")


def test_dask_with_a_worker_killed_mid_campaign_gives_the_same_bytes(dask_client):
    tasks = small_plan(duration_s=2.0)
    reference = campaign.run(tasks)
    killed = []

    def kill_one_worker(done, total):
        if killed or done < 2 or done >= total:
            return
        busy = [w for w, keys in dask_client.processing().items() if keys]
        if not busy:
            return
        pid = dask_client.run(os.getpid, workers=busy[:1])[busy[0]]
        os.kill(pid, signal.SIGKILL)  # the LocalCluster's worker processes run on this machine
        killed.append((done, total, pid))

    r = campaign.run(tasks, dask_client, progress=kill_one_worker)
    assert killed, "no worker was busy while the campaign ran: nothing was killed"
    done, total, pid = killed[0]
    assert done < total
    print(f"\nkilled worker pid {pid} after {done} of {total} tasks; results came from pids {r.worker_pids}")
    assert r.to_json() == reference.to_json()


def test_ray_gives_the_same_bytes(local_result):
    try:
        import ray
    except ImportError:
        print("ray is not installed: the Ray engine is not tested")
        pytest.skip("ray is not installed")
    ray.init(num_cpus=2, include_dashboard=False)
    try:
        assert campaign.run(small_plan(), "ray").to_json() == local_result.to_json()
    finally:
        ray.shutdown()
