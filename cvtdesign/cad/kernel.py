"""The one boundary to CadQuery and its OpenCascade kernel (OCP): both are imported here, inside `kernel()`,
on first use, so the model, `compare`, `optimise` and `study` never load them (importing any cad module
does not either)."""
from __future__ import annotations

import functools
from types import SimpleNamespace


@functools.cache
def kernel() -> SimpleNamespace:
    """cadquery (`cq`) and the OpenCascade classes the cad modules use, imported on the first call."""
    import cadquery as cq
    from cadquery.occ_impl.assembly import toCAF
    from cadquery.occ_impl.exporters.svg import getSVG
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.BRep import BRep_Tool
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.Interface import Interface_HArray1OfHAsciiString, Interface_Static
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_StepModelType
    from OCP.TCollection import TCollection_HAsciiString
    from OCP.TopAbs import TopAbs_Orientation
    from OCP.TopLoc import TopLoc_Location
    from OCP.XSControl import XSControl_WorkSession

    return SimpleNamespace(
        cq=cq, toCAF=toCAF, getSVG=getSVG, MakeHeader=APIHeaderSection_MakeHeader, Common=BRepAlgoAPI_Common,
        DistShapeShape=BRepExtrema_DistShapeShape, gp_Ax2=gp_Ax2, gp_Dir=gp_Dir, gp_Pnt=gp_Pnt,
        written=IFSelect_ReturnStatus.IFSelect_RetDone, HArray1OfHAsciiString=Interface_HArray1OfHAsciiString,
        Static=Interface_Static, STEPCAFControl_Writer=STEPCAFControl_Writer,
        as_is=STEPControl_StepModelType.STEPControl_AsIs, HAsciiString=TCollection_HAsciiString,
        WorkSession=XSControl_WorkSession, triangulation=BRep_Tool.Triangulation_s, Location=TopLoc_Location,
        reversed=TopAbs_Orientation.TopAbs_REVERSED)
