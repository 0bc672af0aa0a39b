"""Files in and out: BVH (reader and writer) into and from clips."""

from .bvh import format_bvh, parse_bvh, read_bvh, write_bvh

__all__ = ["format_bvh", "parse_bvh", "read_bvh", "write_bvh"]
