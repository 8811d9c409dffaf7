"""PyBullet segmentation masks to per-pixel (model, link) labels.

Rendered with ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX a pixel holds uid + ((link + 1) << 24); without
the flag it holds the plain uid. Both decode the same way (a plain uid reads as link −1, the base link,
which is what it is), so one decoder serves both. Negative values are background.
"""

from __future__ import annotations

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.perception.types import Labeler, LabelMap

_UID_BITS = 24
_UID_MASK = (1 << _UID_BITS) - 1


def decode_mask_value(value: int) -> tuple[int, int]:
    """One mask value to (body_uid, link_index); (−1, −1) for background."""
    if value < 0:
        return (-1, -1)
    return (value & _UID_MASK, (value >> _UID_BITS) - 1)


def decode_mask(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A whole mask to (body_uids, link_indices) int arrays of the same shape; −1/−1 for background."""
    m = np.asarray(mask).astype(np.int64)
    bg = m < 0
    uids = np.where(bg, -1, m & _UID_MASK)
    links = np.where(bg, -1, (m >> _UID_BITS) - 1)
    return uids, links


def label_pixels(mask: np.ndarray, labeler: Labeler) -> LabelMap:
    """Label every pixel with its (model, link); the labeler is called once per distinct mask value."""
    m = np.asarray(mask)
    if m.ndim != 2:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"segmentation mask must be 2-D, got shape {m.shape}",
                         "pass CameraImage.segmentation rendered with segmentation=True")
    values, inverse = np.unique(m, return_inverse=True)
    inverse = inverse.reshape(m.shape)
    labels: list[tuple[str, str]] = []
    uids: list[int] = []
    links: list[int] = []
    index: dict[tuple[str, str], int] = {}
    remap = np.full(values.size, -1, dtype=np.int32)
    for i, value in enumerate(values.tolist()):
        uid, link = decode_mask_value(int(value))
        if uid < 0:
            continue
        key = labeler(uid, link)
        if key not in index:  # two encodings of one body/link share a label
            index[key] = len(labels)
            labels.append(key)
            uids.append(uid)
            links.append(link)
        remap[i] = index[key]
    return LabelMap(remap[inverse], tuple(labels), tuple(uids), tuple(links))

