"""Device profiles (docs/spec.md §5 "Device profiles"): a device described by data, not by code.

A profile is a small TOML file: the device's kind and protocol, its nominal rate and line
speed, for a mat its geometry (shape, pitch, origin, axis directions) and the order of its
rows and columns on the wire, and its measurement chain (R_o, V_ref, bits, R_mux, R_adc).
psmat ships the thesis' devices and a do-it-yourself mat (``psmat profiles`` lists them); a
new mat is a new file, ``load_profile("my_mat.toml")``.

* :class:`Profile` — one device (``circuit()``, ``to_dict()``/``from_dict()``, ``to_toml()``,
  ``with_shape()``, ``wire_to_logical()``, ``cell_area_cm2``);
* :class:`Geometry` — where a mat's cells are, in cm (``cell_centres_cm()``);
* :func:`load_profile`, :func:`list_profiles`, :data:`DEFAULT_PROFILE` (the thesis' mat, whose
  geometry and circuit are the processing's defaults: :func:`default_profile`,
  :func:`default_geometry`; :func:`geometry_for` the geometry a CoP is computed on);
* :func:`session_profile` — the profile a loaded session was recorded with;
* :class:`ProfileError` — every bad key or value, one line naming the file and the key.

Each lives in a private module of this package; the names below are the package's API.
"""

from ._errors import ProfileError
from ._geometry import AXES, Geometry
from ._load import (DEFAULT_PROFILE, default_geometry, default_profile, geometry_for, list_profiles, load_profile,
                    parse_toml, profile_names)
from ._profile import Profile
from ._session import session_profile

__all__ = ["Profile", "Geometry", "AXES", "ProfileError", "DEFAULT_PROFILE", "load_profile", "list_profiles",
           "profile_names", "default_profile", "default_geometry", "geometry_for", "parse_toml",
           "session_profile"]
