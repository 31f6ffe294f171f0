"""impactsim: explicit Lagrangian simulation of high-velocity impact between solid bodies."""

import os as _os

__version__ = "0.1.0"

# numba's parallel kernels run on OpenMP threads. With the default ("active") wait policy a
# thread that finishes its share spins at a barrier; on a machine whose cores other processes
# also use, the spinning threads take the time the working thread needs, and every parallel
# kernel waits for a descheduled thread: the coarse sphere-plate scene ran 51-60 s with two
# threads against 20-31 s with passive waiting (docs/performance.md, "Busy machines"). Passive
# waiting costs a thread wake-up per parallel kernel (microseconds) on an idle machine. Set
# before numba loads OpenMP; a value the user set wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

# every kernel calls its own copies of the functions it calls, whether this process compiled it
# or loaded it from the cache: the same bits either way (numba_linking.py; applied when numba's
# code generator loads)
from impactsim import numba_linking as _numba_linking  # noqa: E402

_numba_linking.install()
