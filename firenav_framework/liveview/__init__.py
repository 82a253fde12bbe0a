"""The incident commander's view: conditions, latched alarms and a browser page.

* :mod:`.status`: the conditions per firefighter (device silent, man down, untrusted
  position, map contradiction) on the timeline clock, shared by the ``live_view`` and
  ``mavlink_out`` sinks so both say the same thing.
* :mod:`.alarms`: alarms latched until acknowledged, and their incident-log texts.
* :mod:`.plan`: the floor plan as the page draws it; where true north is.
* :mod:`.feed`: snapshots for the web clients, taken without making the pipeline wait.
* :mod:`.access`: the Host check and the optional token.
* :mod:`.server`: the standard-library HTTP server (page, plan, state, Server-Sent
  Events, acknowledgements).
* ``index.html``, ``app.js``, ``style.css``: the page (plain JS, SVG, no build step).
"""
