"""The Lambert-sphere family in Mitsuba 3.

* :mod:`.plugin`: the registered BSDF plugin ``lambert_sphere`` (docs/mitsuba.md), evaluating the generated
  Dr.Jit code;
* :mod:`.render`: the family's render (``fitlab render``): sphere renders with the plugin against the generated C, the
  comparison image of ``fitlab render``, and the loader of generated Python modules.

Mitsuba is imported only when a function here is called (the ``render`` extra).
"""
