"""The plotting process: a forked process with matplotlib imported that draws one figure while its parent computes."""
from __future__ import annotations

import gc
import multiprocessing
import os
import signal

from cvtdesign.io.output import OutputError
from cvtdesign.io.plots.base import figure_parts


def worker(conn, parent_end):
    """Plotting process: imports matplotlib at once (while the parent computes), then draws what it is
    sent, (a figure function of this package, args), and answers None or an error text. Interrupted (Background.close),
    it stops quietly: output.write_file has removed the file it was writing.

    It draws one figure and ends, so Python's cyclic garbage collector stays off: its passes would walk
    matplotlib's objects and the parent's (about a seventh of the process's time) for cycles that the end of
    the process frees anyway; the memory it uses stays the same."""
    gc.disable()
    parent_end.close()      # its copy of the parent's end: without it, a parent that dies would not be noticed
    failed = None
    try:
        figure_parts()
    except KeyboardInterrupt:
        return
    except Exception as e:  # noqa: BLE001 — reported to the parent with its request, unless interrupted
        if _interrupted(e):
            return
        failed = f"{type(e).__name__}: {e}"
    try:
        figure, args = conn.recv()
        if failed:
            conn.send(failed)
            return
        figure(*args)
        conn.send(None)
    except (EOFError, BrokenPipeError, KeyboardInterrupt):
        return
    except OutputError as e:  # raised again by the parent (Background.wait): one line, exit status 2
        conn.send(e)
    except Exception as e:  # noqa: BLE001 — reported by the parent as one line, unless interrupted
        if not _interrupted(e):
            conn.send(f"{type(e).__name__}: {e}")


def _interrupted(e: BaseException) -> bool:
    """Whether `e` comes of Background.close's interrupt: a KeyboardInterrupt inside C code (an extension
    module being imported, say) surfaces as another exception caused by it, and its traceback on stderr would
    follow the parent's one-line error."""
    while e is not None:
        if isinstance(e, KeyboardInterrupt):
            return True
        e = e.__cause__ or e.__context__
    return False


class Background:
    """Run a figure function of this package in a forked process that has matplotlib ready.

    Start it before the computation; `draw` hands over the data; `wait` returns the error text or None
    (a file that could not be written is raised as the OutputError it was); `close` ends the process if it
    still runs, without leaving a half-written file."""

    def __init__(self):
        ctx = multiprocessing.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=worker, args=(child, self.conn), daemon=True)
        self.proc.start()
        child.close()

    def draw(self, figure, *args):
        """Have the process call figure(*args) (a figure function of this package, sent by reference)."""
        self.conn.send((figure, args))

    def wait(self):
        try:
            answer = self.conn.recv()
        except EOFError:
            return "the plotting process ended unexpectedly"
        finally:
            self.close()
        if isinstance(answer, OutputError):
            raise answer
        return answer

    def close(self):
        """After an answer the process ends by itself; otherwise (the parent failed) it is interrupted, so a
        file it is writing is removed (output.write_file), and ended if it does not stop."""
        self.proc.join(timeout=0.1)
        if self.proc.is_alive():
            os.kill(self.proc.pid, signal.SIGINT)
            self.proc.join(timeout=5)
        if self.proc.is_alive():
            self.proc.terminate()
            self.proc.join()
        self.conn.close()
