"""The interactive viewer in the browser: ``cdbrdf view`` (WebGL2, no JS library).

- :mod:`cdbrdf.view.asset`: a table packed for the GPU (binary + JSON header,
  the lookup grid of :func:`cdbrdf.interp.prepare` as a texture array) and
  the surfaces' meshes;
- :mod:`cdbrdf.view.export`: the self-contained static folder (HTML, JS, the
  assets embedded so that it opens from ``file://``);
- :mod:`cdbrdf.view.server`: the local web server of ``cdbrdf view``;
- :mod:`cdbrdf.view.gltf_page`: the browser renderer of a glTF export
  (``cdbrdf view x.glb``: three.js, bundled from ``js/``).

The page itself (``assets/viewer.html``, ``assets/viewer.js``, the GLSL
lookup ``assets/lookup.js``) is package
data; ``docs/viewer.md`` describes it, its JavaScript interface
(``window.cdbrdfViewer``) and the GPU layout.
"""

from __future__ import annotations

__all__ = ["asset", "export", "gltf_page", "server"]
