"""``psmat lab``: a local web application to acquire, watch, mark, record and replay mat sessions.

A Starlette application served by uvicorn in the process that reads the device: the page
(``static/``: plain JavaScript and canvases, no CDN, no build step) shows the raw counts, the
pressure and the centre-of-pressure trace pushed over a WebSocket, and drives the recording
(subject, trial, note, markers) and the replay of the data folder's sessions through a JSON API.

* :class:`LabSession` - the acquisition / recording / display / replay state (private module
  ``_session``); :func:`trial_sway` - the sway metrics of a recorded trial;
* :func:`build_app` - the web application (``_app``); :class:`TokenGuard` - the token check
  every request passes; :class:`ClientHub` - the WebSocket clients;
* :func:`new_token`, :func:`confine`, :func:`safe_component`, :func:`is_loopback`,
  :class:`PathRefused` - the guards (``_security``);
* :class:`DisplayFeed` - the display worker (``_display``); :class:`Replay`, :func:`open_replay`
  (``_replay``); :class:`CalibrationWalk` - the box's open/short calibration walk-through
  (``_calibrate``; ``POST /api/calibrate/...``).

Security: the server binds 127.0.0.1 unless told otherwise, every request and WebSocket needs
the random token printed in the URL, and every file it reads or writes lies in the data folder.
"""

from ._app import STATIC_DIR, ClientHub, TokenGuard, build_app
from ._calibrate import CalibrationWalk
from ._display import DisplayFeed
from ._replay import PlaybackUnavailable, Replay, open_replay
from ._security import PathRefused, confine, is_loopback, new_token, request_token, safe_component, token_matches
from ._session import LabConflict, LabSession, trial_sway

__all__ = ["LabSession", "LabConflict", "trial_sway", "build_app", "TokenGuard", "ClientHub", "STATIC_DIR",
           "DisplayFeed", "Replay", "open_replay", "PlaybackUnavailable", "new_token", "token_matches",
           "request_token", "confine", "safe_component", "is_loopback", "PathRefused", "CalibrationWalk"]
