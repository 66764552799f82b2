"""A batch's plant side and physics on N flagship worlds (docs/validation.md "A batch's plants and physics").

1. CPU time a world-tick (thread time, the least of 3 chunks of `--ticks` ticks) of the actuator
   read-out, the command and a truth sample, each world's plant (`PerWorldPlants`) against the
   CMG group (`CmgPlant.group_form`), and of their step() beside the bare mj_step loop; the
   commands hold drifting levels that jump at 3 % of the ticks (the flagship's refined share).
2. Four ways to step the worlds a control tick at a time: mj_step per world, a thread pool of 2
   over mj_step, `mujoco.rollout` with each world's state out of and into its MjData, and
   `mujoco.batch.Batch` on the worlds' models; wall and CPU time a world-tick, the least of 3.

    .venv/bin/python bench/bench_batch_plants.py [N ...] [--ticks T]
"""

import argparse
import concurrent.futures
import time

import mujoco
import mujoco.batch
import mujoco.rollout
import numpy as np

import testbed
from testbed.batch.plant_group import PerWorldPlants
from testbed.run_core.plan import prepare
from testbed.systems.cmg_cluster.plants_group import CmgPlantGroup

FLAGSHIP = "lebedev_spinup_cmg"


def flagship_plants(count: int) -> list:
    return [prepare(testbed.load(FLAGSHIP, [f"initial.omega_deg_s=[{0.25 + 0.01 * i},-0.25,0.0]"])).plant
            for i in range(count)]


def plant_side(count: int, ticks: int) -> None:
    rng = np.random.default_rng(0)
    jumps = (rng.random((3 * ticks, count, 1)) < 0.03) * rng.normal(0.0, 0.05, (3 * ticks, count, 4))
    commands = np.cumsum(rng.normal(0.0, 1e-4, (3 * ticks, count, 4)) + jumps, axis=0)
    worlds = flagship_plants(count)
    steps = round(prepare(testbed.load(FLAGSHIP)).timing.steps_per_tick)
    per = count * ticks / 1e6
    for kind in (PerWorldPlants, CmgPlantGroup):
        group = kind(worlds, steps)
        sides, stepping = [], []
        for chunk in range(3):
            side = stepped = 0.0
            for k in range(chunk * ticks, (chunk + 1) * ticks):
                t0 = time.thread_time()
                group.actuator_state()
                group.apply({"gimbal_rates": commands[k]})
                group.truth()
                t1 = time.thread_time()
                group.step()
                side, stepped = side + t1 - t0, stepped + time.thread_time() - t1
            sides.append(side)
            stepping.append(stepped)
        for row in range(count):
            group.settle(row)
        print(f"N={count:4d} {kind.__name__:15s} read+command+truth {min(sides) / per:6.1f} us, "
              f"step {min(stepping) / per:6.1f} us a world-tick")
    t0 = time.thread_time()
    for _ in range(ticks):
        for plant in worlds:
            mujoco.mj_step(plant.model, plant.data, steps)
    print(f"N={count:4d} bare mj_step {(time.thread_time() - t0) / per:6.1f} us a world-tick")


def least(call, count: int, ticks: int) -> str:
    wall, cpu = [], []
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.process_time()
        call()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    per = count * ticks / 1e6
    return f"wall {min(wall) / per:6.1f} us, cpu {min(cpu) / per:6.1f} us a world-tick"


def stepping(count: int, ticks: int) -> None:
    plans = [prepare(testbed.load(FLAGSHIP, [f"initial.omega_deg_s=[{0.25 + 0.01 * i},-0.25,0.0]"]))
             for i in range(count)]
    models = [plan.plant.model for plan in plans]
    steps = plans[0].timing.steps_per_tick
    datas = [mujoco.MjData(model) for model in models]

    def loop():
        for _ in range(ticks):
            for model, data in zip(models, datas):
                mujoco.mj_step(model, data, steps)

    print(f"N={count:4d} mj_step per world        {least(loop, count, ticks)}")
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        halves = [list(range(k, count, 2)) for k in range(2)]

        def work(rows):
            for i in rows:
                mujoco.mj_step(models[i], datas[i], steps)

        def threads():
            for _ in range(ticks):
                list(pool.map(work, halves))

        print(f"N={count:4d} thread pool of 2          {least(threads, count, ticks)}")
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.zeros((count, mujoco.mj_stateSize(models[0], spec)))
    control = np.zeros((count, steps, models[0].nu))
    out = np.zeros((count, steps, initial.shape[1]))
    for nthread in (0, 2):
        with mujoco.rollout.Rollout(nthread=nthread) as rollout:
            scratch = [mujoco.MjData(models[0]) for _ in range(max(nthread, 1))]

            def rolled():
                for _ in range(ticks):
                    for i, data in enumerate(datas):
                        mujoco.mj_getState(models[i], data, initial[i], spec)
                        control[i] = data.ctrl
                    rollout.rollout(models, scratch, initial, control, state=out)
                    for i, data in enumerate(datas):
                        mujoco.mj_setState(models[i], data, out[i, -1], spec)

            print(f"N={count:4d} mujoco.rollout nthread {nthread} {least(rolled, count, ticks)}")
    for nthread in (1, 2):
        batch = mujoco.batch.Batch(models[0], count, nthread=nthread, persistent=True)
        batch.set_models(models)
        print(f"N={count:4d} mujoco.batch nthread {nthread}   "
              f"{least(lambda: [batch.step(nstep=steps) for _ in range(ticks)], count, ticks)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("worlds", nargs="*", type=int, default=[16, 64])
    parser.add_argument("--ticks", type=int, default=100)
    args = parser.parse_args()
    for count in args.worlds:
        plant_side(count, args.ticks)
        stepping(count, args.ticks)


if __name__ == "__main__":
    main()
