"""The main job: ``polywear report``, one section per part of the product.

``main`` runs the analyses and writes the page; each section module (``wear``, ...)
turns results into text, tables and figures without computing them again.
"""

from .main import Report, report, text_summary

__all__ = ["Report", "report", "text_summary"]
