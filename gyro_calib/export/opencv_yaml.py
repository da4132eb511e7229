"""OpenCV ``FileStorage`` YAML (OpenVINS, VINS-Fusion): the ``%YAML:1.0`` header.

OpenCV writes and expects a first line ``%YAML:1.0`` (a colon where YAML 1.1 has a space),
which PyYAML rejects as a malformed directive. :func:`with_header` writes it;
:func:`read_opencv_yaml` checks it and reads the rest as plain YAML (block mappings, flow
sequences and ``#`` comments, the subset both OpenCV and these consumers use).

OpenCV's YAML reader keeps an inline ``# comment`` inside a plain (unquoted) string scalar:
``model: kalibr  # note`` reads ``'kalibr  # note'``. Every string is therefore written
double-quoted (:func:`opencv_string`), after which OpenCV, like YAML, ends the scalar at the
closing quote; numbers end at the first blank either way.
"""

from __future__ import annotations

from typing import Any

import yaml

HEADER = '%YAML:1.0'


class OpenCvYamlError(ValueError):
    """The text is not an OpenCV YAML file (no ``%YAML:1.0`` first line, or bad YAML)."""


def opencv_string(value: str) -> str:
    """``value`` double-quoted, so OpenCV's reader stops at the quote, not at a comment.

    Raises:
        ValueError: ``value`` holds a quote, backslash or line break (no topic or model
            name does; OpenCV and YAML would read such a string differently).
    """
    if any(c in value for c in '"\\\n\r'):
        raise ValueError(f'{value!r}: a quote, backslash or line break cannot be written '
                         'as an OpenCV string')
    return f'"{value}"'


def with_header(body: str) -> str:
    """``%YAML:1.0``, a document start, then ``body``."""
    return f'{HEADER}\n---\n{body}'


def read_opencv_yaml(text: str) -> dict[str, Any]:
    """The mapping of an OpenCV YAML text.

    Raises:
        OpenCvYamlError: the first line is not ``%YAML:1.0`` or the rest is not a mapping.
    """
    first, _, rest = text.partition('\n')
    if first.strip() != HEADER:
        raise OpenCvYamlError(f'the first line must be {HEADER} (OpenCV FileStorage); got '
                              f'{first!r:.40}')
    try:
        data = yaml.safe_load(rest)
    except yaml.YAMLError as exc:
        raise OpenCvYamlError(f'not valid YAML after the header: {exc}') from None
    if not isinstance(data, dict):
        raise OpenCvYamlError('the document is not a mapping')
    return data
