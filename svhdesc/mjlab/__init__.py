"""The SVH in mjlab (PyPI ``mjlab``: Isaac Lab's manager API on MuJoCo Warp): entities for the built variants
(``svhdesc.mjlab.entity``) and the tasks ``Svh-Rotate`` and ``Ur5-Svh-Lift`` registered through mjlab's
``mjlab.tasks`` entry point (``svhdesc.mjlab.tasks``), so that mjlab's own ``train`` and ``play`` run them.

Needs ``pip install 'svhdesc[mjlab]'`` in an environment of its own: mjlab pins MuJoCo and MuJoCo Warp 3.11 and
rsl-rl-lib 5.4.2, older than svhdesc's other extras (docs/learning.md, "In mjlab"). This package's modules import
mjlab only inside functions, except ``svhdesc.mjlab.tasks``, which mjlab itself imports."""
