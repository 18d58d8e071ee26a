"""`gazed run RIG`: start the rig's processes, watch them, restart them, talk to systemd.

- Holds the bus: a router-mode zenoh session on the rig's `[bus] listen` endpoints (or a client
  of an external router when `[bus] router = false`).
- Starts every enabled process in `[services]` as `python -m <module> --rig RIG` in its own
  session (terminal signals reach only the supervisor; children die with it, see
  services/runtime.py). A process is up when its liveliness token
  `gazed/<rig>/alive/<name>/<pid>` appears, with the pid of the run just started (a late token
  of a run that has died is not its restart's); a process whose module is not installed is
  reported as missing and skipped.
- Restarts a process that exits, or whose token vanishes while it still runs (frozen: killed
  first), after a backoff that doubles from `[services] backoff_initial_s` to `backoff_max_s`.
  More than `restart_max` restarts of one process within `restart_window_s` -> stop
  everything, exit 1, and let systemd take over.
- systemd: `READY=1` once every enabled process is up, `WATCHDOG=1` from this loop at half of
  `WATCHDOG_USEC` while healthy, `STATUS=` on changes, `STOPPING=1` on stop.
- SIGTERM/SIGINT: orderly stop (SIGTERM to children, SIGKILL after `stop_grace_s`).
  SIGHUP: re-read the rig; an invalid one is reported and the old one kept; a valid one
  restarts only the processes whose sections changed (`gazed.topics.PROCESSES` declares the
  sections each reads).
- Publishes `gazed/<rig>/supervisor/status` once a second and on every change.
- Shows the loop (`console.LiveStatus`): a live status line in a terminal; under systemd a log
  line per gaze state change.

Modules: `child` (one supervised process), `machine` (the state machine, `Supervisor`),
`reload` (which processes a new rig restarts), `command` (`gazed run` itself).
"""
