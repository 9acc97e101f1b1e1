"""The text of an XML document (a URDF, an MJCF file, a clearance file) from its bytes.

Decoded as its byte-order mark or its XML declaration says (UTF-8 without either), the
declaration removed (Pinocchio's parsers read UTF-8 text). Bad bytes or malformed XML are a
:class:`~clearance_pin.errors.ModelError` on ``<xml>``.
"""

from __future__ import annotations

import codecs
import re
import warnings
import xml.etree.ElementTree as ET
import xml.parsers.expat

from ..errors import ArgumentError, ModelError

_DECLARATION = re.compile(r"^\ufeff?\s*<\?xml\b[^>]*\?>")
_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"),
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)


def decode_xml(data: bytes, source: str = "<string>") -> str:
    """The text of an XML document: decoded as its byte-order mark or its declaration says
    (UTF-8 without either), with the declaration removed (Pinocchio's parser reads UTF-8 text)."""
    declared: list[str | None] = []
    parser = xml.parsers.expat.ParserCreate()
    parser.XmlDeclHandler = lambda version, encoding, standalone: declared.append(encoding)
    try:
        with warnings.catch_warnings():  # expat tries every byte of a declared unicode_escape,
            warnings.simplefilter("ignore", DeprecationWarning)  # each bad escape warned
            parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise ModelError(source, "<xml>", f"malformed XML: {exc}") from None
    except ValueError as exc:  # expat refuses a declared multi-byte encoding (utf-32, utf-7)
        raise ModelError(source, "<xml>", f"cannot be decoded: {exc}") from None
    encoding = next((name for bom, name in _BOMS if data.startswith(bom)), None)
    encoding = encoding or (declared[0] if declared and declared[0] else "utf-8")
    try:
        text = data.decode(encoding)
    except (UnicodeDecodeError, LookupError) as exc:
        raise ModelError(source, "<xml>", f"cannot be decoded as {encoding}: {exc}") from None
    _check_characters(text, source, f"after decoding as {encoding}")
    return without_declaration(text)


def _check_characters(text: str, source: str, how: str) -> None:
    """``text`` has no lone surrogate (a declared ``unicode_escape`` decodes ``\\ud800`` to one,
    a str from Python may hold one): not a character, and Pinocchio's parsers read UTF-8."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise ModelError(
            source,
            "<xml>",
            f"a lone surrogate {text[exc.start]!r} at character {exc.start} {how} (not a "
            "character; the parsers read UTF-8)",
        ) from None


def without_declaration(text: str) -> str:
    """``text`` without its XML declaration."""
    return _DECLARATION.sub("", text, count=1)


def xml_text(text: object, source: str, argument: str = "text") -> str:
    """The text of a document given as str (its declaration removed) or bytes (decoded)."""
    if isinstance(text, (bytes, bytearray)):
        return decode_xml(bytes(text), source)
    if not isinstance(text, str):
        raise ArgumentError(argument, "the model file's text (str or bytes)", text)
    _check_characters(text, source, "of the text given")
    return without_declaration(text)


def parse(text: str, source: str) -> ET.Element:
    """The root element of ``text``."""
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        raise ModelError(source, "<xml>", f"malformed XML: {exc}") from None


__all__ = ["decode_xml", "parse", "without_declaration", "xml_text"]
