"""A process's line of Linux ``/proc/PID/stat``, read in one place (proc(5)): its start time (the
output lock, a command's timings), its parent (the workers to reap) and its CPU time (the hang
watch of the render pool). Elsewhere, or for a process that is gone, there is none."""

from __future__ import annotations

# indices into `stat_fields` (proc(5)'s field numbers less 3: the list starts after the command name)
PPID = 1  # field 4: the parent's process id
UTIME, STIME = 11, 12  # fields 14 and 15: CPU time in user and kernel mode [clock ticks]
STARTTIME = 19  # field 22: start time after boot [clock ticks]


def stat_fields(pid: int | str) -> list[str] | None:
    """The fields of ``/proc/PID/stat`` after the command name (which may hold spaces and
    parentheses, so the line is split after its last ')'), state first; None where there is no
    such file (not Linux, or the process has ended)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            line = f.read().decode("ascii", "replace")
        return line.rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
