"""The one error of the benchmarks: a scenario could not run (its message names the process and its log's last
lines). Its own module, so that every bench and its helpers raise and catch the same class, whichever of them runs
as ``__main__``."""


class BenchError(RuntimeError):
    """A scenario could not run; the message names the process and its log's last lines."""
