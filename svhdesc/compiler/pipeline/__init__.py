"""The one owner of a build: the steps in order (steps.py), the out folder and its swap, the manifest, freshness."""
