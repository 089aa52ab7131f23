"""Type stub for the compiled core psmat._core (private; use the psmat package API).

This folder holds stubs only (no __init__.py): the compiled extension module
``_core.*.so`` takes precedence at import time.
"""

from . import iecm as iecm
from . import qzpm as qzpm
from . import firmware as firmware
from . import sensor as sensor
