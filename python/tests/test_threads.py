"""The GIL is released while the core runs: monitors in parallel threads give the sequential answers."""

from concurrent.futures import ThreadPoolExecutor

import pmon


def run(path):
    rec = pmon.read_recording(path)
    monitor = pmon.Monitor(rec.params)
    return [r for f in rec for r in monitor.check_frame(f).records()]


def test_two_threads_give_the_sequential_records(sim_recording):
    sequential = run(sim_recording)
    with ThreadPoolExecutor(max_workers=2) as pool:
        a, b = pool.map(run, [sim_recording, sim_recording])
    assert a == sequential and b == sequential
