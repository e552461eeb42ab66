"""The thesis' chapter-5 experiment on several physics engines: ``svhdesc compare``.

``experiment`` defines the run (surface, servo schedule, eq. 5.1) once, for this and for ``svhdesc
validate``; ``engine`` is the small interface every adapter implements (``mujoco_engine``,
``dart_engine``, ``bullet_engine``, ``drake_engine``, ``ode_engine``, each importing its engine only when
used);
``runner`` runs the engine x inertia grid and computes the metrics; ``report`` prints and writes them.
"""
