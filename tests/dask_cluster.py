"""Options for the tests' Dask LocalClusters.

A scheduler always runs an HTTP server (health, metrics), on port 8787 unless told otherwise, even
with ``dashboard_address=None``. When two test workers start a cluster at the same moment, the
second finds 8787 taken and warns, and the suite's warnings filter turns that into an error. The
tests' clusters therefore put that server on a free loopback port."""

#: ``scheduler_kwargs`` for ``distributed.LocalCluster(..., dashboard_address=None)``: the
#: scheduler's HTTP server on a free port of 127.0.0.1, without the dashboard.
LOOPBACK_HTTP = {"dashboard_address": "127.0.0.1:0"}
