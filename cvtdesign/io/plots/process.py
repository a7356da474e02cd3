"""Forked processes that work while their parent computes: `Forked` runs one function sent to it and answers
with what it returned or raised; `Background` is the plotting process, a Forked that imports matplotlib at once
and draws one figure. (cad.export also forks one to draw the SVG beside the STEP export.)"""
from __future__ import annotations

import gc
import multiprocessing
import os
import signal

from cvtdesign.io.output import OutputError
from cvtdesign.io.plots.base import figure_parts


def worker(conn, parent_end, warm=None, call=None):
    """The forked process: runs `warm()` at once (while the parent computes), then `call` (fn, args) if given
    (its arguments are the parent's objects, copied by the fork: nothing is pickled), else the one (fn, args)
    it is sent, and answers (True, fn(*args)) or (False, the exception it raised, or its text 'Type: message' when
    it cannot be pickled). Interrupted (Forked.close), it stops quietly: output.write_file has removed a file it was
    writing.

    It runs one call and ends, so Python's cyclic garbage collector stays off: its passes would walk
    matplotlib's objects and the parent's (about a seventh of the process's time) for cycles that the end of
    the process frees anyway; the memory it uses stays the same.

    Its interrupt is its own: a parent started with SIGINT ignored (by `nohup`, or as a background job of a
    shell without job control) would hand that on through the fork, and close() would then wait its whole
    timeout for every process it ends (5 s a failing command) before terminating it. It starts with SIGINT blocked
    (Forked), so an interrupt sent at once waits until its handler is there: before it, the interrupt would
    have been raised in the fork's copy of the parent's code."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    gc.disable()
    parent_end.close()      # its copy of the parent's end: without it, a parent that dies would not be noticed
    failed = None
    try:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})    # one sent since the fork arrives here
        if warm is not None:
            warm()
    except KeyboardInterrupt:
        return
    except Exception as e:  # noqa: BLE001 — reported to the parent with its request, unless interrupted
        if _interrupted(e):
            return
        failed = e
    try:
        fn, args = call if call is not None else conn.recv()
        answer = (False, failed) if failed else (True, fn(*args))
    except (EOFError, BrokenPipeError, KeyboardInterrupt):
        return
    except Exception as e:  # noqa: BLE001 — raised again or reported by the parent, unless interrupted
        if _interrupted(e):
            return
        answer = (False, e)
    try:
        conn.send(answer)
    except (EOFError, BrokenPipeError):
        return
    except Exception as e:  # noqa: BLE001 — an answer that cannot be pickled
        conn.send((False, describe(answer[1]) if not answer[0] else f"{type(e).__name__}: {e}"))


def describe(error) -> str:
    """An answer's error as one line: 'Type: message' (an error the process could only describe is its text)."""
    return error if isinstance(error, str) else f"{type(error).__name__}: {error}"


def _interrupted(e: BaseException) -> bool:
    """Whether `e` comes of Forked.close's interrupt: a KeyboardInterrupt inside C code (an extension module
    being imported, say) surfaces as another exception caused by it, and its traceback on stderr would follow
    the parent's one-line error."""
    while e is not None:
        if isinstance(e, KeyboardInterrupt):
            return True
        e = e.__cause__ or e.__context__
    return False


class Forked:
    """A forked copy of this process (it has what this one imported and built) that runs one function on the
    other core: start it early with the call (`call`: (fn, args), whose arguments the fork copies) or `send`
    it the call later, `answer` gives (ok, value or exception), `close` ends it if it still runs, without
    leaving a half-written file. `warm`: what it runs at once, before the call."""

    def __init__(self, warm=None, call=None):
        ctx = multiprocessing.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=worker, args=(child, self.conn, warm, call), daemon=True)
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})     # in the child until `worker`
        try:                                                                  # handles it
            self.proc.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
        child.close()
        self.answered = False

    def send(self, fn, *args):
        """Have the process call fn(*args) (a module-level function, sent by reference)."""
        self.conn.send((fn, args))

    def answer(self) -> tuple:
        """(True, what the call returned) or (False, what it raised, or its text; None: the process ended
        without answering); the process is closed after."""
        try:
            return self.conn.recv()
        except EOFError:
            return False, None
        finally:
            self.answered = True
            self.close()

    def close(self):
        """After an answer the process ends by itself; otherwise (the parent failed) it is interrupted at once,
        so a file it is writing is removed (output.write_file), and ended if it does not stop. (Waiting for it
        first cost every refused command 0.1 s: a process still warming up or waiting for its call never ends
        by itself.)"""
        if self.answered:
            self.proc.join(timeout=0.1)
        if self.proc.is_alive():
            os.kill(self.proc.pid, signal.SIGINT)
            self.proc.join(timeout=5)
        if self.proc.is_alive():
            self.proc.terminate()
            self.proc.join()
        self.conn.close()


class Background(Forked):
    """The plotting process: a Forked with matplotlib imported at once, that draws one figure function of this
    package. `draw` hands over the data; `wait` returns None or the error's text (a file that could not be
    written is raised as the OutputError it was)."""

    def __init__(self):
        super().__init__(warm=figure_parts)

    def draw(self, figure, *args):
        self.send(figure, *args)

    def wait(self):
        ok, value = self.answer()
        if ok:
            return None
        if isinstance(value, OutputError):
            raise value
        return "the plotting process ended unexpectedly" if value is None else describe(value)
