"""The DEM engine: builds the parts of a system and runs whole steps.

A step (velocity Verlet, LIGGGHTS' initial/final integrate):
  1. half kick and drift                                        (particles.py)
  2. rebuild the neighbour list if the last step flagged it   (neighbours.py)
  3. wall poses at the new time                                 (motion.py)
  4. sphere-sphere contacts, once per pair, into the list slots (pairs.py)
  5. per particle: gather the pair slots, wall contacts, half kick, skin check
                                                                (neighbours.py, walls.py)
Three ways to run steps, chosen once per system (`Engine.launch`):
- serial: many whole steps per launch, parallel over replicas and serial inside each
  (small systems and batches of replicas, where launch overhead would dominate);
- team: many whole steps per launch by a team of CPU threads sharing the particles, with a
  barrier between phases (large systems on a CPU with two or more threads; team.py); when
  chosen automatically, its pacer runs the steps on one thread (the serial launch) while that
  is faster, as when another process takes one of the cores (team.Pacer);
- parallel: one kernel launch per step, parallel over particles (a GPU).
All call the same functions per particle.  Serial and team runs end a particle's step and
start its next (half kick, drift) in one pass; every launch rebuilds a due list after the
drift, from the positions it reached, so the rebuilds fall on the same steps whatever the
launch (and its length, or a pacer's switches): the rebuild count is a function of the
trajectory alone.  When the list is rebuilt changes no bits anyway (it holds every contact
then), so every launch gives identical results, and none depends on the number of threads.
"""

import logging
import pickle
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import taichi as ti
from taichi.lang.field import Field
from tqdm import tqdm

from .checkpoint import Checkpoint, SettledBed
from .contact import PairTables
from .energy import N_OUT, EnergyBook, named_totals
from .layout import Allocation, LayoutMismatch, allocating
from .monitor import CELL, FLAGS, NEIGHBOURS, WALL_CONTACTS, Monitor
from .motion import Motions
from .neighbours import NeighbourList
from .pairs import PairContacts
from .particles import Particles, capacity
from .results import Recorder, Results
from .runtime import cpu_threads, init_taichi, keep_engine, kept_engine
from .system import SystemSpec
from .team import SPACING, Pacer, Team, block_lead
from .transfer import FieldSet, field_set, nbytes
from .walls import LOAD_COLUMNS, Walls, mean_loads

log = logging.getLogger(__name__)

# A replica with more particles than this searches a cell grid; fewer (an MM400 jar holds 1-2
# balls) test all pairs, which for a handful of balls costs less than binning them.
GRID_MIN_PARTICLES = 8
# Below this many particles a CPU runs whole steps serially in one launch; from it on, a team of
# threads does (a team's barriers cost ~0.1-0.2 us; 2 threads against 1: 1.1-1.2x at 523 balls,
# 1.6x at 1,000, 1.9x at 8,640).  A parallel loop costs ~70 us to dispatch on this machine.
TEAM_MIN_PARTICLES = 500
LAUNCHES = ("serial", "team", "parallel")
# A serial launch's replicas are shared by the threads in this many runs per thread (a calibration
# grid: 200 one-ball jars; Taichi's CPU runtime would run a loop over them on one thread).
BATCHES_PER_THREAD = 4
# Memory of the engine's fields (f64), measured on a 3,645-ball drum: 525 B per particle, plus the
# 4 B that pad a partner's record to 96 B, the 8 B masks of open contacts and of records in use
# and the 4 B mask of walls within reach added since, less the 48 B of the own list's sums (now
# in the particle's force and torque), and 32 B per buffered collision; from the
# fields' sizes, 109 B per neighbour-list slot (partner, reverse slot, the name of its contact's
# records, a contact's records of history and of force and torque, 48 B each with padding, and
# a rebuild's new partner: 4+4+1+96+4) and 144 B per wall-contact slot (key, history and force,
# double buffered: 2 x (4+4+8+8+24+24)).
PARTICLE_BYTES, PAIR_SLOT_BYTES, WALL_SLOT_BYTES, EVENT_BYTES = 501, 109, 144, 32
DRIFT, POSE, PAIRS, FINISH = 1, 2, 4, 8  # phases of a step
BUILD, LINK = 16, 32  # phases of a neighbour-list rebuild
STEP = DRIFT | POSE | PAIRS | FINISH


class SimulationError(RuntimeError):
    """The run went unphysical; the message says what happened and what to change."""


@dataclass(frozen=True)
class Observation:
    """What a sample reads of the engine, in one launch: positions (m), velocities (m/s) and
    spins (rad/s), (n, 3) each; the mean wall loads since the last sample (walls.mean_loads);
    the energy book's totals per replica (J, energy.named_totals); the monitor's flags by name."""

    x: np.ndarray
    v: np.ndarray
    w: np.ndarray
    loads: dict[str, np.ndarray]
    book: dict[str, np.ndarray]
    flags: dict[str, float]


def memory_estimate_bytes(n_particles: int, max_contacts: int, event_capacity: int, wall_slots: int) -> float:
    """Memory the engine's fields will take (bytes, f64; fields hold capacity(n) particles;
    wall_slots: walls.wall_slots of the system)."""
    per_particle = PARTICLE_BYTES + PAIR_SLOT_BYTES * max_contacts + WALL_SLOT_BYTES * wall_slots
    return capacity(n_particles) * per_particle + EVENT_BYTES * event_capacity


@dataclass(frozen=True)
class EngineOptions:
    """Numerical settings (SI).  dt_s is the time step actually used.

    skin_fraction: neighbour-list skin as a fraction of the largest radius (larger: fewer
    rebuilds, more candidate pairs; results agree to round-off whatever the skin).
    grid: None picks a cell grid when some replica has more than GRID_MIN_PARTICLES.
    launch: one of LAUNCHES; None: serial for replica batches, systems of fewer than
    TEAM_MIN_PARTICLES and one CPU thread, else team on a CPU and parallel on a GPU.
    parallel_binning: None bins particles into cells serially on a CPU (faster than launching
    threads) and in parallel, then sorts each cell, on a GPU; True/False forces one path.
    """

    dt_s: float
    max_contacts_per_particle: int = 16
    event_capacity: int = 200_000
    max_overlap_fraction: float = 0.05
    skin_fraction: float = 0.5
    grid: bool | None = None
    launch: str | None = None
    collision_log: bool = True  # False compiles the collision log out (dense beds make millions)
    progress_every_s: float = 30.0
    parallel_binning: bool | None = None  # None: serial on a CPU, parallel binning + per-cell sort elsewhere


@ti.data_oriented
class Engine:
    """A Taichi DEM system built from a SystemSpec; Taichi must already be initialised
    (`new_engine` starts it, or takes the last engine again)."""

    def __init__(self, spec: SystemSpec, options: EngineOptions):
        self._allocation = Allocation()
        with allocating(self._allocation):
            self._build(spec, options)
        self._signature = kernel_signature(self)
        self._start()

    def reload(self, spec: SystemSpec, options: EngineOptions) -> bool:
        """Take another system into this engine, keeping its fields and so the kernels Taichi
        compiled for them, when the system's fields have the same shapes and its kernels the same
        compile-time values (kernel_signature): then the engine starts as a new one would, the
        same bits (tests/test_engine_reuse.py).  False when they differ: the engine is then of
        no use until Taichi restarts."""
        if not self._rebuild(spec, options) or kernel_signature(self) != self._signature:
            return False
        self._allocation.zero()  # as new fields are, then the system's values again
        self._rebuild(spec, options)
        self._start()
        return True

    def _rebuild(self, spec: SystemSpec, options: EngineOptions) -> bool:
        """_build into this engine's fields; False when the system's fields would have other shapes."""
        try:
            with allocating(self._allocation), self._allocation.replaying():
                self._build(spec, options)
        except LayoutMismatch:
            return False
        return True

    def _build(self, spec: SystemSpec, options: EngineOptions) -> None:
        """The parts and their fields, set to the system's values."""
        self.spec, self.opt, self.dt = spec, options, options.dt_s
        self.p = Particles(spec)
        self.p.dt[None] = self.dt
        self.n, self.n_rep, self.n_body = self.p.n, self.p.n_rep, len(spec.bodies)
        self.use_grid = bool(self.p.counts.max() > GRID_MIN_PARTICLES) if options.grid is None else options.grid
        self.launch = self._choose_launch() if options.launch is None else options.launch
        if self.launch not in LAUNCHES:
            raise ValueError(f"launch={self.launch!r} is not one of {LAUNCHES}")
        k = options.max_contacts_per_particle
        self.monitor = Monitor(options.event_capacity)
        self.tables = PairTables(spec)
        self.mo = Motions(spec, self.n_rep)
        skin = options.skin_fraction * float(spec.radius_m.max())
        self.book = EnergyBook(self.p)
        self.walls = Walls(spec, self.p, self.tables, self.mo, self.monitor, self.book, k, options.collision_log)
        self.nl = NeighbourList(spec, self.p, self.monitor, self.walls, k, skin, self.use_grid,
                                options.parallel_binning)
        self.pairs = PairContacts(self.p, self.tables, self.nl, self.monitor, self.book, options.collision_log)
        threads = max(ti.lang.impl.current_cfg().cpu_max_num_threads, 1)
        self.team = Team(threads, self.n) if self.launch == "team" else None
        # the launch chosen here (not asked for) runs on one thread while that is faster
        self.pacer = Pacer(self.n, threads) if self.team and options.launch is None else None
        self.batches = min(self.n_rep, BATCHES_PER_THREAD * threads)  # of replicas, in a serial launch
        self.max_overlap = self.monitor.max_overlap

    def _start(self) -> None:
        """The first list build and forces, at step 0."""
        self.step_index = 0
        if self.launch == "parallel":
            self.nl.build_all()
            self._first_forces()
        else:  # the list (due from the start), then the first forces; compiles what a team's pacer may run
            self._serial_steps(0, 0)
        self.book.cumulative.fill(0.0)  # the first forces set the stored energies; no time has passed
        self._due = bool(self.nl.any_due[None])
        self._accumulated_steps = 1
        self.initial_energy_j = _stored(self._energy_now(*self.kinematics(), self.book.totals()))

    def _choose_launch(self) -> str:
        cfg = ti.lang.impl.current_cfg()
        on_cpu = cfg.arch == ti.cpu
        if self.n_rep > 1 or (on_cpu and (cfg.cpu_max_num_threads == 1 or self.n < TEAM_MIN_PARTICLES)):
            return "serial"
        return "team" if on_cpu else "parallel"

    # ---------------------------------------------------------------- kernels
    @ti.func
    def finish(self, i, k, kick):
        """Step end for particle i: total force and torque, second half kick (if `kick`), skin check."""
        f_pairs, t_pairs = self.nl.gather(i)
        f_walls, t_walls = self.walls.forces(i, k)
        self.p.f[i] = self.p.mass[i] * self.p.gravity[None] + f_pairs + f_walls
        self.p.tq[i] = t_pairs + t_walls
        if kick:
            self.p.kick(i)
        self.nl.watch(i)

    @ti.kernel
    def _first_forces(self):
        for r, b in ti.ndrange(self.n_rep, self.n_body):
            self.mo.pose(r, b, 0.0)
        for i in range(self.p.live[None]):
            self.pairs.forces(i, 0)
        for i in range(self.p.live[None]):
            self.finish(i, 0, False)

    @ti.kernel
    def _step(self, k: ti.i32, phases: ti.template()) -> ti.i32:
        """Step k, parallel over particles; returns 1 when the list must be rebuilt first."""
        if ti.static(phases & DRIFT):
            for i in range(self.p.live[None]):
                self.p.kick_drift(i, self.monitor)
        if ti.static(phases & POSE):
            ti.loop_config(serialize=True)
            for r in range(self.n_rep):
                for b in range(self.n_body):
                    self.mo.pose(r, b, k * self.p.dt[None])
        if ti.static(phases & PAIRS):
            for i in range(self.p.live[None]):
                self.pairs.forces(i, k)
        if ti.static(phases & FINISH):
            for i in range(self.p.live[None]):
                self.finish(i, k, True)
        return self.nl.any_due[None]

    @ti.kernel
    def _serial_steps(self, k0: ti.i32, nsteps: ti.i32):
        """nsteps whole steps of every replica: parallel over replicas, serial inside each, one
        pass over the particles a step (i's pair contacts only read partners j > i, which have
        not yet ended the step; i ends its step once every lower partner has written i's slots,
        then, unless the launch ends there, starts the next); a due rebuild comes after that
        drift.  nsteps = 0: the forces at step k0 with no kick (a new engine's first forces,
        after its first list build), so no other kernel compiles the contact code.  The replicas
        are cut into `batches` runs of consecutive replicas, each the only work of its block of
        the loop (as a team's members: team.py), so that the threads share them."""
        for q in range(self.batches * SPACING):
            g = block_lead(q)  # -1: no replicas
            for r in range(ti.max(g, 0) * self.n_rep // self.batches, (g + 1) * self.n_rep // self.batches):
                i0, i1 = self.p.rep_start[r], self.p.rep_end[r]
                for i in range(i0, i1 if nsteps > 0 else i0):  # the first step's half kick and drift
                    self.p.kick_drift(i, self.monitor)
                for s in range(ti.max(nsteps, 1)):
                    k = k0 + s + ti.min(nsteps, 1)
                    if self.nl.due[r]:
                        self.nl.build_replica(r)
                    for b in range(self.n_body):
                        self.mo.pose(r, b, k * self.p.dt[None])
                    for i in range(i0, i1):  # the step's end and, unless the launch ends here, the next's start
                        self.pairs.forces(i, k)
                        self.finish(i, k, nsteps > 0)
                        if s < nsteps - 1:
                            self.p.kick_drift(i, self.monitor)
        ti.loop_config(serialize=True)
        for _ in range(1):  # a team launch that follows reads the replicas' flags as one
            self.nl.gather_due()

    @ti.func
    def team_phase(self, t, phase_id, k, phase: ti.template(), drift):
        """Member t's share of one phase: its own chunks, then chunks of members still busy (team.py);
        returns the next phase's number.  `drift`: whether a DRIFT in `phase` is done."""
        chunk, n = self.team.chunk[None], self.p.live[None]
        for v in range(self.team.size):
            first, last = self.team.own((t + v) % self.team.size)
            for m in range(last - first):
                c = first + m if v == 0 else last - 1 - m
                if self.team.take(c, phase_id):
                    for i in range(c * chunk, ti.min((c + 1) * chunk, n)):
                        self.particle_phase(i, k, phase, drift)
        return phase_id + 1

    @ti.func
    def particle_phase(self, i, k, phase: ti.template(), drift):
        """Particle i's part of the phases in `phase` (bits), in step order: its pair contacts,
        the step's end (FINISH), then, if `drift`, the next step's half kick and drift (DRIFT; a
        run-time flag, so that the launch's last step compiles the step's end no second time)."""
        if ti.static(phase & PAIRS):
            self.pairs.forces(i, k)
        if ti.static(phase & FINISH):
            self.finish(i, k, True)
        if ti.static(phase & DRIFT):  # noqa: SIM102 (compiled out when static; `drift` at run time)
            if drift:
                self.p.kick_drift(i, self.monitor)
        if ti.static(phase & BUILD):
            self.nl.build_particle(i)
        if ti.static(phase & LINK):
            self.nl.link_reverse(i)

    @ti.kernel
    def _team_steps(self, k0: ti.i32, nsteps: ti.i32):
        """nsteps whole steps by the team, two barriers a step: wall poses (member 0) and pair
        contacts; then, in one pass per particle, wall contacts, the second half kick and the
        next step's half kick and drift (a particle's end of step reads no other particle, so
        the pass gives the same bits as two).  A rebuild, when due, comes after that drift:
        when the list is rebuilt does not change the results (it holds every contact then)."""
        ti.loop_config(block_dim=SPACING)
        for q in range(self.team.members):
            t, phase_id, passed = block_lead(q), 0, 0
            if t >= 0 and nsteps > 0:  # the first step's half kick and drift
                phase_id = self.team_phase(t, phase_id, k0 + 1, DRIFT, True)
                passed = self.team.barrier(passed)
            for s in range(nsteps if t >= 0 else 0):
                k = k0 + s + 1
                if ti.atomic_or(self.nl.any_due[None], 0):
                    if t == 0:
                        self.nl.bin_all()
                    passed = self.team.barrier(passed)
                    phase_id = self.team_phase(t, phase_id, k, BUILD, False)
                    passed = self.team.barrier(passed)
                    phase_id = self.team_phase(t, phase_id, k, LINK, False)
                    if t == 0:
                        self.nl.built()
                    passed = self.team.barrier(passed)
                if t == 0:
                    for r, b in ti.ndrange(self.n_rep, self.n_body):
                        self.mo.pose(r, b, k * self.p.dt[None])
                phase_id = self.team_phase(t, phase_id, k, PAIRS, False)
                passed = self.team.barrier(passed)
                # the step's end and, unless the launch ends here, the next step's start
                phase_id = self.team_phase(t, phase_id, k, FINISH | DRIFT, s < nsteps - 1)
                passed = self.team.barrier(passed)

    @ti.kernel
    def _observe(self, kin: ti.types.ndarray(), loads: ti.types.ndarray(), book: ti.types.ndarray(),
                 flags: ti.types.ndarray()):
        self.p.export_kinematics(kin)
        self.walls.export_loads(loads)
        self.book.export(book)
        self.monitor.export_flags(flags)

    @ti.kernel
    def _kinematics(self, kin: ti.types.ndarray()):
        self.p.export_kinematics(kin)

    # ---------------------------------------------------------------- driving
    def _run_steps(self, kind: str, nsteps: int) -> None:
        """nsteps steps by the serial or the team launch (a team engine may run either: same bits)."""
        if kind == "serial":
            self._serial_steps(self.step_index, nsteps)
            self.step_index += nsteps
            return
        done = 0
        while done < nsteps:  # launches short enough that the team's i32 counters cannot overflow
            part = min(nsteps - done, self.team.max_steps_per_launch)
            self.team.reset()
            self._team_steps(self.step_index, part)
            self.step_index += part
            done += part

    def advance(self, nsteps: int) -> None:
        """Advance nsteps time steps (none: nothing happens)."""
        if nsteps <= 0:
            return
        if self.launch == "parallel":
            for _ in range(nsteps):
                self.step_index += 1
                if self._due:  # after the drift, as the serial and team launches rebuild
                    self._step(self.step_index, DRIFT)
                    self.nl.build_all()
                    self._due = bool(self._step(self.step_index, STEP & ~DRIFT))
                else:
                    self._due = bool(self._step(self.step_index, STEP))
        elif self.pacer:
            done = 0
            while done < nsteps:
                kind, part = self.pacer.plan(nsteps - done)
                t0 = time.perf_counter()
                self._run_steps(kind, part)
                self.pacer.record(kind, part, time.perf_counter() - t0)
                done += part
        else:
            self._run_steps(self.launch, nsteps)
        self._accumulated_steps += nsteps

    def profile(self, nsteps: int) -> dict[str, float]:
        """Seconds of compute per phase over nsteps steps from a fresh list, each phase launched
        on its own and synchronised, less the cost of launching an empty step (reported as
        "launch").  The fresh list also compiles the parallel rebuild, which a serial engine has
        not used, and clears the due flag its per-replica rebuilds leave set."""
        phases = {"integrate": DRIFT, "wall motion": POSE, "pair contacts": PAIRS, "wall contacts and gather": FINISH}
        spent = dict.fromkeys(["neighbour list", *phases, "launch"], 0.0)

        def timed(call, *args):
            t0 = time.perf_counter()
            out = call(*args)
            ti.sync()
            return out, time.perf_counter() - t0

        self._step(self.step_index, 0)  # compile every variant before timing
        self.nl.build_all()
        due = False
        for s in range(nsteps + 1):
            if due:
                _, t = timed(self.nl.build_all)
                spent["neighbour list"] += t
            self.step_index += 1
            _, launch = timed(self._step, self.step_index, 0)
            for name, phase in phases.items():
                due, t = timed(self._step, self.step_index, phase)
                spent[name] += max(t - launch, 0.0)
            spent["launch"] += launch
            if s == 0:
                spent = dict.fromkeys(spent, 0.0)  # the first step compiled the kernels
        self._due = bool(due)
        self._accumulated_steps += nsteps + 1
        return spent

    def run(self, duration_s: float, sample_every_s: float, recorder: Recorder | None = None,
            label: str = "run", checkpoint: Checkpoint | None = None, phases: tuple = (),
            stop: Callable[[], bool] | None = None, bed: SettledBed | None = None) -> Results:
        """Advance by duration_s, sampling every sample_every_s (rounded to whole steps); with a
        checkpoint, continue an interrupted run from it and save one every checkpoint.every_wall_s
        of wall-clock time (at a sample: where it falls changes no result);
        `stop()`, asked after every sample, ends the run early when it returns True; with a
        settled bed, start from it when one was saved, else save it on the way at its step.

        Progress: a bar (simulated time, phase, particle-steps per second, ETA) on a terminal,
        else a log line every `progress_every_s`; `phases` are (start time (s), name) pairs."""
        recorder = recorder or Recorder(self)
        per_sample = max(1, round(sample_every_s / self.dt))
        n_samples = max(1, round(duration_s / (per_sample * self.dt)))
        start = self.step_index
        first = checkpoint.resume(self, recorder, label) if checkpoint else 0
        if not first and bed is not None and bed.restore(self, recorder):  # saved before its step's sample
            first = (self.step_index - start - 1) // per_sample
        bar = tqdm(total=n_samples, initial=first, desc=label, unit="sample",
                   disable=not sys.stderr.isatty())
        t_wall = last_log = saved_at = time.perf_counter()
        for s in range(first, n_samples):
            target = start + (s + 1) * per_sample
            if bed is not None and self.step_index < bed.step <= target:
                self.advance(bed.step - self.step_index)
                bed.save(self, recorder)
            self.advance(target - self.step_index)
            seen = self.observe()
            self.check(seen)
            recorder.sample(self, seen)
            now = time.perf_counter()
            if checkpoint and s < n_samples - 1 and now - saved_at >= checkpoint.every_wall_s:
                checkpoint.save(self, recorder, s + 1, label)
                saved_at = now
            rate = (s + 1 - first) * per_sample * self.n / (now - t_wall)
            phase = next((name for start, name in reversed(phases) if self.time_s >= start), "")
            bar.set_postfix_str(f"t={self.time_s:.3f} s {phase}, {rate:.3g} particle-steps/s", refresh=False)
            bar.update(1)
            if bar.disable and (now - last_log > self.opt.progress_every_s or s == n_samples - 1):
                log.info("%s: t=%.4f s %s(%d/%d samples), %.3g particle-steps/s", label,
                         self.time_s, f"{phase} " if phase else "", s + 1, n_samples, rate)
                last_log = now
            if stop is not None and stop():
                break
        bar.close()
        return recorder.finish(self)

    @property
    def _state_fields(self) -> FieldSet:
        """The fields each part names as its STATE, moved in one launch (compiled on first use)."""
        return field_set({f"{part}.{name}": getattr(getattr(self, part), name)
                          for part in ("p", "nl", "walls", "book", "monitor") for name in type(getattr(self, part)).STATE})

    def state(self) -> dict:
        """Everything a run needs to continue: the fields each part names as its STATE, and the
        counters.  The rest is the spec's (constants, geometry, the wall motions, posed anew
        every step) or recomputed by the list rebuild that follows a restore."""
        return {"fields": self._state_fields.read(),
                "step_index": self.step_index, "accumulated_steps": self._accumulated_steps,
                "initial_energy_j": self.initial_energy_j}

    def restore(self, state: dict) -> None:
        """Set the state's fields and counters.  The neighbour list is rebuilt before the next
        step: the state may come from a run with another launch, and when the list is rebuilt
        does not change the results (tests/test_neighbour_list.py)."""
        self._state_fields.write(state["fields"])
        self.step_index = state["step_index"]
        self._accumulated_steps, self.initial_energy_j = state["accumulated_steps"], state["initial_energy_j"]
        self.nl.due.fill(1)
        self.nl.any_due[None] = 1
        self._due = True

    @property
    def time_s(self) -> float:
        return self.step_index * self.dt

    def contact_counts(self) -> np.ndarray:
        """Open contacts of each particle now (with particles and walls)."""
        open_ = self.nl.open_slots()
        counts = open_.sum(axis=1)
        np.add.at(counts, self.nl.nb_j.to_numpy()[:self.n][open_], 1)
        return counts + self.walls.c_n.to_numpy()[self.step_index % 2, :self.n]

    def field_bytes(self) -> int:
        """Bytes the fields of the engine's parts hold, from their shapes and types (a field
        that two parts share counted once)."""
        fields = {id(f): f for part in vars(self).values() if type(part).__module__.startswith(__package__)
                  for f in vars(part).values() if isinstance(f, Field)}
        return sum(nbytes(f) for f in fields.values())

    def contacts_per_particle(self) -> float:
        return float(self.contact_counts().mean())

    def rebuilds(self) -> int:
        """Neighbour-list builds so far (all replicas)."""
        return int(self.nl.builds[None])

    def observe(self) -> Observation:
        """Read what a sample records, in one launch; drains the wall loads."""
        kin, book = np.zeros((3, self.n, 3)), np.zeros((self.n_rep, N_OUT))
        loads, flags = np.zeros((self.n_rep, max(self.n_body, 1), LOAD_COLUMNS)), np.zeros(len(FLAGS))
        self._observe(kin, loads, book, flags)
        steps, self._accumulated_steps = self._accumulated_steps, 0
        return Observation(*kin, mean_loads(loads, steps), named_totals(book),
                           dict(zip(FLAGS, flags.tolist())))

    def check(self, seen: Observation) -> None:
        """Stop with a clear message when the run went unphysical (seen: this step's observation)."""
        m, t, x, flag = self.monitor, f"t={self.time_s:.6g} s", seen.x, {k: int(v) for k, v in seen.flags.items()}
        if not np.isfinite(x).all():
            raise SimulationError(
                f"non-finite particle position at {t}: reduce sim.dt_fraction "
                "(time step as a fraction of Rayleigh) or check material stiffness"
            )
        if flag["escaped"]:
            i = flag["escaped"] - 1
            raise SimulationError(
                f"particle {i} left the vessel's domain at {t} (position "
                f"{x[i].round(5).tolist()} m): the time step is too large for the wall speed "
                "or stiffness, or the particles were placed outside the walls"
            )
        if flag["fast"]:
            raise SimulationError(
                f"particle {flag['fast'] - 1} moved more than half the neighbour skin "
                f"({self.nl.skin / 2:.3g} m) in one step at {t}: reduce sim.dt_fraction or raise sim.neighbour_skin"
            )
        if flag["overflow"]:
            k = self.opt.max_contacts_per_particle
            what = {NEIGHBOURS: f"more neighbours within the skin than sim.max_contacts_per_particle={k}; "
                                "raise it, or lower sim.neighbour_skin",
                    WALL_CONTACTS: f"more wall contacts than sim.max_contacts_per_particle={k}; raise it",
                    CELL: "more particles in a grid cell than its capacity (heavy overlap)"}[flag["overflow"]]
            raise SimulationError(f"a particle had {what} (at {t})")
        if seen.flags["max_overlap"] > self.opt.max_overlap_fraction:
            raise SimulationError(
                f"overlap reached {100 * seen.flags['max_overlap']:.2f} % of a radius at {t} "
                f"(limit {100 * self.opt.max_overlap_fraction:.1f} %): reduce sim.dt_fraction, or "
                "raise the shear modulus if it was reduced for speed"
            )
        if flag["ev_count"] > m.capacity:
            raise SimulationError(
                f"{flag['ev_count']} collisions ended since the log was last read, more than "
                f"sim.event_capacity={m.capacity} (read once half full, at a sample): raise it or sample more often"
            )

    def energies(self, seen: Observation) -> dict[str, np.ndarray]:
        """Per replica (J), at the step `seen` was observed: kinetic, rotational, potential (zero at
        the origin) and elastic energy; the cumulative wall work and dissipation (energy.CHANNELS);
        and the residual of the balance since the engine was built, work - change of stored
        energy - dissipation."""
        out = self._energy_now(seen.x, seen.v, seen.w, seen.book)
        lost = out["dissipated_normal_j"] + out["dissipated_tangential_j"] + out["dissipated_rolling_j"]
        out["residual_j"] = out["wall_work_j"] - (_stored(out) - self.initial_energy_j) - lost
        return out

    def _energy_now(self, x, v, w, book: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        m, reps = self.p.mass_np, self.spec.replica

        def per_replica(q):
            return np.bincount(reps, q, minlength=self.n_rep)

        return {"kinetic_j": per_replica(0.5 * m * (v**2).sum(1)),
                "rotational_j": per_replica(0.2 * m * self.spec.radius_m**2 * (w**2).sum(1)),
                "potential_j": per_replica(-m * (x @ np.asarray(self.spec.gravity_m_per_s2))),
                **book}

    def kinematics(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions (m), velocities (m/s) and spins (rad/s) of the particles now, (n, 3) each."""
        kin = np.zeros((3, self.n, 3))
        self._kinematics(kin)
        return kin[0], kin[1], kin[2]

    def drain_events(self) -> tuple[np.ndarray, np.ndarray]:
        """Collisions ended since the last call: ints (i, partner, start, end step), values."""
        return self.monitor.drain()

    def wall_axis(self) -> np.ndarray:
        """(replicas, bodies, 3) motion axes (world)."""
        return self.mo.axis_np


# What an engine's parts hold that no kernel reads: the system's host-side copies, the options
# (their compiled values are the parts'), run counters, the pacer's timings, the bookkeeping.
HOST_SIDE = frozenset({"spec", "opt", "dt", "n", "counts", "mass_np", "axis_np", "wall_body", "mesh_body", "n_chunks",
                       "pacer", "step_index", "_due", "_accumulated_steps", "initial_energy_j", "_allocation",
                       "_signature"})


def kernel_signature(engine: Engine) -> tuple:
    """Every value but a field that the engine and its parts hold, by where it is held (HOST_SIDE
    left out): what Taichi may have compiled into the kernels as constants (loop bounds, the
    skin, the cell size, which code paths exist).  Engines whose signatures are equal and whose
    fields have the same shapes run the same compiled kernels."""
    values, seen = [], set()

    def walk(part, path: str) -> None:
        seen.add(id(part))
        for name, value in vars(part).items():
            if name in HOST_SIDE or isinstance(value, Field) or id(value) in seen:
                continue
            if type(value).__module__.startswith(__package__) and hasattr(value, "__dict__"):
                walk(value, f"{path}.{name}")
            else:
                try:
                    values.append((f"{path}.{name}", pickle.dumps(value)))
                except Exception:  # noqa: BLE001 (unpicklable: by its repr, which names the object: never equal)
                    values.append((f"{path}.{name}", repr(value)))

    walk(engine, "engine")
    return tuple(values)


def new_engine(spec: SystemSpec, options: EngineOptions, arch: str = "cpu", precision: str = "f64",
               threads: int = 0, seed: int = 0) -> Engine:
    """An engine for the system with Taichi started for these settings: the last engine this
    process built (with new_engine) taken again when the system fits its compiled kernels
    (Engine.reload), which saves compiling or loading them from Taichi's cache (~2-3 s a run);
    else Taichi restarted (init_taichi) and a new engine built.  No kernel draws Taichi's random
    numbers, so the seed is not among the settings an engine is kept for."""
    settings = (arch, precision, cpu_threads(threads))
    kept = kept_engine(settings)
    if kept is not None and kept.reload(spec, options):
        log.debug("the last engine taken again: its kernels fit this system")
        return kept
    init_taichi(arch, precision, threads, seed)
    engine = Engine(spec, options)
    keep_engine(settings, engine)
    return engine


def _stored(energy: dict[str, np.ndarray]) -> np.ndarray:
    return energy["kinetic_j"] + energy["rotational_j"] + energy["potential_j"] + energy["elastic_j"]
