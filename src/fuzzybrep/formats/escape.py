"""Strings from a map or a file name, made safe for the file they are written into: one function
per context, which every writer uses (the viewer's HTML page, SVG, ROS YAML, PGM comments).

A map's unit, a file's name and any other string a user or an attacker controls is text, never
markup: ``<!--<script>`` as a unit swallowed the viewer's own script, a file name holding
``<img src=x onerror=...>`` ran in the page, a control character made an SVG ill-formed and a
newline in a file name split a YAML value over two lines. Nothing is dropped: what a context
cannot hold is written as a visible escape (``\\x01``, ``\\ud800``), so the reader still sees
that something odd was there.
"""

from __future__ import annotations

import json
import re

#: characters XML 1.0 cannot hold at all, not even as a character reference: C0 controls other
#: than tab, newline and carriage return, lone surrogates, U+FFFE and U+FFFF
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
#: what a YAML plain scalar may be without quotes: a plain file name that starts with a letter
#: (so that no reader takes it for a number: 1e5, 0x10, 1_000 are numbers to YAML 1.1) and is
#: no YAML 1.1 boolean or null, nor a word Python's float() reads (nan, inf)
_YAML_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]*")
_YAML_WORDS = {"y", "n", "yes", "no", "on", "off", "true", "false", "null", "nan", "inf", "infinity"}
_YAML_ESCAPES = {"\\": "\\\\", '"': '\\"', "\n": "\\n", "\t": "\\t", "\r": "\\r", "\0": "\\0"}
#: what YAML's double-quoted style must escape (1.2, 5.1: the printable set excludes these)
_NOT_YAML = re.compile('[\\\\"\x00-\x1f\x7f-\x9f\ud800-\udfff\ufffe\uffff\u2028\u2029\ufeff]')


def _visible(c: str) -> str:
    """``\\xNN`` or ``\\uNNNN``: a character shown as its code."""
    n = ord(c)
    return f"\\x{n:02x}" if n < 0x100 else f"\\u{n:04x}" if n < 0x10000 else f"\\U{n:08x}"


def printable(s: str) -> str:
    """``s`` as text that encodes as UTF-8: a lone surrogate (from JSON's ``"\\ud800"``, or a file
    name's undecodable byte, which Python holds as one) becomes its visible escape."""
    return s.encode("utf-8", "backslashreplace").decode("utf-8")


def xml_text(s: str) -> str:
    """Text content of an XML or HTML element: &, < and > escaped, what XML cannot hold visible."""
    s = _NOT_XML.sub(lambda m: _visible(m.group()), str(s))
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def xml_attribute(s: str) -> str:
    """An XML or HTML attribute value, to go between double quotes."""
    return (xml_text(s).replace('"', "&quot;").replace("'", "&#39;")
            .replace("\n", "&#10;").replace("\r", "&#13;").replace("\t", "&#9;"))


html_text = xml_text
html_attribute = xml_attribute


def script_json(obj) -> str:
    """JSON to sit inside an HTML ``<script>`` element: ASCII only (a lone surrogate stays the
    escape ``\\ud800``, which JSON.parse reads back), and no <, > or & at all, so that neither
    ``</script>`` nor ``<!--`` in a string can end or hide the element (both are the same
    JSON string written as ``\\u003c``...)."""
    text = json.dumps(obj, separators=(",", ":"), ensure_ascii=True)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def yaml_scalar(s: str) -> str:
    """A string as a YAML scalar that every YAML reader reads back as the same string: plain when
    it is a plain file name, else double-quoted with YAML's escapes (a newline as ``\\n``: in single
    quotes a line break folds into a space, and the value spanned two lines)."""
    s = str(s)
    if _YAML_PLAIN.fullmatch(s) and s.lower() not in _YAML_WORDS:
        return s
    return '"' + _NOT_YAML.sub(lambda m: _YAML_ESCAPES.get(m.group()) or _visible(m.group()), s) + '"'


_YAML_UNESCAPE = re.compile(r'\\(x[0-9a-fA-F]{2}|u[0-9a-fA-F]{4}|U[0-9a-fA-F]{8}|.)', re.S)
_YAML_SIMPLE = {"0": "\0", "a": "\a", "b": "\b", "t": "\t", "\t": "\t", "n": "\n", "v": "\v", "f": "\f", "r": "\r",
                "e": "\x1b", " ": " ", '"': '"', "/": "/", "\\": "\\", "N": "\x85", "_": "\xa0", "L": "\u2028",
                "P": "\u2029"}


def yaml_unquote_double(body: str) -> str:
    """The string a YAML double-quoted scalar holds (``body``: between the quotes, on one line)."""

    def one(m: re.Match) -> str:
        e = m.group(1)
        if e[0] in "xuU" and len(e) > 1:
            return chr(int(e[1:], 16))
        if e in _YAML_SIMPLE:
            return _YAML_SIMPLE[e]
        raise ValueError(f"unknown escape \\{e} in a double-quoted string")

    return _YAML_UNESCAPE.sub(one, body)


def comment_line(s: str) -> str:
    """One line of ASCII for a comment in a text header (a PGM's): what is not printable ASCII
    (a newline would end the comment, and a byte above 127 was a UnicodeEncodeError) is escaped."""
    return re.sub(r"[^\x20-\x7e]", lambda m: _visible(m.group()), str(s))


__all__ = ["comment_line", "html_attribute", "html_text", "printable", "script_json", "xml_attribute", "xml_text",
           "yaml_scalar", "yaml_unquote_double"]
