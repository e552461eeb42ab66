"""The thesis' chapter-5 experiment on several physics engines: ``svhdesc compare``.

``experiment`` defines the run (surface, servo schedule, eq. 5.1) once; one adapter module per engine
(``mujoco_engine``, ``dart_engine``, ``bullet_engine``, ``drake_engine``) imports its engine only when
used; ``runner`` runs the engine x inertia grid and ``report`` prints and writes the results.
"""
