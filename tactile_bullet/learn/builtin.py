"""The built-in descriptors, registered as a default plugin exactly as a third party's are.

Kept apart from the descriptor modules so that none of them imports another only to register
it (``descriptors`` <-> ``time_series`` was a loop): this module sits above them all.
"""

from __future__ import annotations

from ..hookspecs import hookimpl


@hookimpl
def register_descriptors(register):
    from .coupled import (
        CoupledJointsDescriptor,
        CoupledSignatureDescriptor,
        CoupledTimeSeriesDescriptor,
    )
    from .descriptors import ContactNormalsDescriptor, RawJointsDescriptor, SignatureDescriptor
    from .finger_points import CoupledFingerPointsDescriptor, FingerPointsDescriptor
    from .robust import (
        RobustCoupledJointsDescriptor,
        RobustJointsDescriptor,
        RobustSignatureDescriptor,
    )
    from .time_series import TimeSeriesDescriptor

    for descriptor in (
        SignatureDescriptor,
        RawJointsDescriptor,
        ContactNormalsDescriptor,
        TimeSeriesDescriptor,
        RobustSignatureDescriptor,
        RobustJointsDescriptor,
        RobustCoupledJointsDescriptor,
        CoupledSignatureDescriptor,
        CoupledJointsDescriptor,
        CoupledTimeSeriesDescriptor,
        FingerPointsDescriptor,
        CoupledFingerPointsDescriptor,
    ):
        register(descriptor.name, descriptor)
