"""ctypes bindings to Debian's libode.so.8 (ODE 0.16, double precision) for what pyode lacks.

Debian's python3-pyode is built without trimesh support and hides body and world ids; these calls
create trimesh geoms, collide them and make contact joints on the same ODE world pyode built.
Structures follow ODE 0.16's include/ode/contact.h.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

LIBODE = "libode.so.8"
# include/ode/contact.h (0.16)
CONTACT_MU2, CONTACT_SOFT_ERP, CONTACT_SOFT_CFM, CONTACT_APPROX1 = 0x001, 0x008, 0x010, 0x7000


class Surface(ctypes.Structure):
    _fields_ = [("mode", ctypes.c_int)] + [
        (name, ctypes.c_double)
        for name in (
            "mu mu2 rho rho2 rhoN bounce bounce_vel soft_erp soft_cfm motion1 motion2 motionN slip1 slip2".split()
        )
    ]


class ContactGeom(ctypes.Structure):
    _fields_ = [
        ("pos", ctypes.c_double * 4),
        ("normal", ctypes.c_double * 4),
        ("depth", ctypes.c_double),
        ("g1", ctypes.c_void_p),
        ("g2", ctypes.c_void_p),
        ("side1", ctypes.c_int),
        ("side2", ctypes.c_int),
    ]


class Contact(ctypes.Structure):
    _fields_ = [("surface", Surface), ("geom", ContactGeom), ("fdir1", ctypes.c_double * 4)]


class Feedback(ctypes.Structure):
    _fields_ = [(name, ctypes.c_double * 4) for name in ("f1", "t1", "f2", "t2")]


def load() -> Any:
    lib = ctypes.CDLL(LIBODE)
    void, real, ptr = None, ctypes.c_double, ctypes.c_void_p
    signatures = {
        "dGeomTriMeshDataCreate": ([], ptr),
        "dGeomTriMeshDataBuildDouble": ([ptr, ptr, ctypes.c_int, ctypes.c_int, ptr, ctypes.c_int, ctypes.c_int], void),
        "dGeomTriMeshDataDestroy": ([ptr], void),
        "dCreateTriMesh": ([ptr, ptr, ptr, ptr, ptr], ptr),
        "dHashSpaceCreate": ([ptr], ptr),
        "dSpaceDestroy": ([ptr], void),
        "dSpaceSetCleanup": ([ptr, ctypes.c_int], void),
        "dGeomSetBody": ([ptr, ptr], void),
        "dGeomGetBody": ([ptr], ptr),
        "dGeomSetOffsetPosition": ([ptr, real, real, real], void),
        "dGeomSetOffsetRotation": ([ptr, ctypes.c_double * 12], void),
        "dBodyGetWorld": ([ptr], ptr),
        "dCollide": ([ptr, ptr, ctypes.c_int, ptr, ctypes.c_int], ctypes.c_int),
        "dSpaceCollide2": ([ptr, ptr, ptr, ptr], void),
        "dJointGroupCreate": ([ctypes.c_int], ptr),
        "dJointGroupEmpty": ([ptr], void),
        "dJointGroupDestroy": ([ptr], void),
        "dJointCreateContact": ([ptr, ptr, ctypes.POINTER(Contact)], ptr),
        "dJointAttach": ([ptr, ptr, ptr], void),
        "dJointSetFeedback": ([ptr, ctypes.POINTER(Feedback)], void),
        "dWorldSetQuickStepW": ([ptr, real], void),
        "dWorldGetQuickStepW": ([ptr], real),
        "dRandSetSeed": ([ctypes.c_ulong], void),
    }
    for name, (args, result) in signatures.items():
        function = getattr(lib, name)
        function.argtypes, function.restype = args, result
    return lib


def matrix3(rotation: np.ndarray) -> Any:
    """An ODE dMatrix3 (3 rows of 4)."""
    values = np.zeros((3, 4))
    values[:, :3] = rotation
    return (ctypes.c_double * 12)(*values.flatten())
