"""The one progress convention of ngcontact: a bar (tqdm) on long runs, or nothing."""
from contextlib import nullcontext

from tqdm.auto import tqdm

from ngcontact import parallel


def bar(total, description, enabled=True, unit="step"):
    """A progress bar of ``total`` units (a context manager with ``update(n)`` and
    ``set_postfix_str(text)``), or a silent stand-in when not ``enabled`` and on the MPI
    ranks other than 0 (under mpiexec)."""
    if not enabled or parallel.rank() != 0:
        return nullcontext(_Silent())
    return tqdm(total=total, desc=description, unit=unit, dynamic_ncols=True, leave=True)


def write(text):
    """Print a line without breaking a progress bar on the screen."""
    tqdm.write(text)


class _Silent:
    def update(self, n=1):
        pass

    def set_postfix_str(self, text):
        pass

    def write(self, text):
        pass
