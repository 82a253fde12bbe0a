"""The incident commander's view: per-firefighter status and a browser page.

* :mod:`.status`: stale / untrustworthy / man-down states per firefighter, shared by
  the ``live_view`` and ``mavlink_out`` sinks so both say the same thing.
* :mod:`.server`: the state the page shows and a small standard-library HTTP server
  (``/`` the page, ``/api/state`` a snapshot, ``/events`` Server-Sent Events).
* ``index.html``, ``app.js``, ``style.css``: the page (plain JS, SVG, no build step).
"""
