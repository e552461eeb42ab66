"""The floor both wings stand on: what the compiler and the contract (svhdesc.model) read alike.

``settings`` (the typed schema, configs, coupling specs), ``source`` (readers of xacro, URDF, meshes and ROS
packages), ``manifest`` (a built variant's record), ``exact`` (CPU-independent arithmetic) and ``frames``.
Nothing here imports svhdesc.compiler, svhdesc.model or a runtime package (tests/test_layout.py keeps it so).
"""
