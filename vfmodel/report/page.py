"""Building blocks of the self-contained HTML reports (``reproduce``, ``diagnose``, ``fit``).

A page is one file: CSS and a few lines of JavaScript inline, figures embedded as base64
PNG, nothing fetched from the network. It opens with a summary (the headline figures against
the reference and the goals with pass/fail marks, what to look at, the key figure), then
the detail. Numbers are written by :func:`vfmodel.report.units.si`; a number taken from the
JSON document carries ``data-key`` (its JSON path) and ``data-unit`` so that a test can
read the page's text and compare it with the document.
"""

from __future__ import annotations

import base64
import html
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vfmodel.report.units import si

__all__ = ["Check", "figure", "html_page", "num", "summary", "table"]

E = html.escape

CSS = """
*{box-sizing:border-box}
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0;color:#1d2430;
background:#f6f7f9;line-height:1.4}
main{max-width:1280px;margin:0 auto;padding:12px 20px 40px}
h1{font-size:1.35em;margin:0.2em 0 0.1em}h2{font-size:1.15em;margin:1.6em 0 0.4em;
border-bottom:2px solid #d5d9e0;padding-bottom:2px}h3{font-size:1em;margin:1.2em 0 0.3em}
.sub{color:#5a6372;margin:0 0 8px;font-size:0.92em}
#summary{display:grid;grid-template-columns:minmax(0,1fr) minmax(0,1fr);gap:14px;
background:#fff;border:1px solid #d5d9e0;border-radius:6px;padding:10px 14px}
#summary .key img{max-height:470px;width:auto;max-width:100%}
.verdict{font-weight:600;font-size:1.05em;margin:2px 0 6px}
table{border-collapse:collapse;margin:6px 0 10px;background:#fff;font-size:0.88em}
td,th{border:1px solid #cfd4dc;padding:2px 7px;text-align:right;vertical-align:top}
th{background:#eef1f5;font-weight:600}td:first-child,th:first-child{text-align:left}
td.text{text-align:left}
.pass{color:#0a7a2f;font-weight:700;white-space:nowrap}.fail{color:#b3261e;font-weight:700;white-space:nowrap}
.info{color:#5a6372}
.flag{color:#b3261e;font-weight:600}.weak{color:#9a6700;font-weight:600}
ul.look{margin:4px 0 4px 1.1em;padding:0;font-size:0.9em}
figure{margin:8px 0;background:#fff;border:1px solid #d5d9e0;border-radius:4px;padding:6px;
display:inline-block;max-width:100%}
figure img{max-width:100%;height:auto;display:block;cursor:zoom-in}
figcaption{font-size:0.82em;color:#5a6372}
.figs{display:flex;flex-wrap:wrap;gap:8px}.figs figure{max-width:calc(50% - 4px)}
#zoom{position:fixed;inset:0;background:rgba(20,24,32,0.88);display:none;overflow:hidden;
cursor:grab;z-index:10}
#zoom img{position:absolute;left:0;top:0;transform-origin:0 0;max-width:none;
background:#fff}
#zoom .hint{position:absolute;right:12px;top:8px;color:#fff;font-size:0.85em}
p.note{font-size:0.88em;color:#3c4450;max-width:60em}
"""

# Click a figure: it opens full size; the wheel zooms about the pointer, a drag pans,
# a double click or Escape closes. No library, no network.
ZOOM_JS = """
(function(){
var box=document.getElementById('zoom');if(!box){return;}
var im=document.createElement('img');im.alt='zoomed figure';box.appendChild(im);
var s=1,x=0,y=0,drag=null;
function put(){im.style.transform='translate('+x+'px,'+y+'px) scale('+s+')';}
function close(){box.style.display='none';}
document.querySelectorAll('figure img').forEach(function(el){
 el.addEventListener('click',function(){im.src=el.src;box.style.display='block';
  var w=el.naturalWidth||1,h=el.naturalHeight||1;
  s=Math.min(window.innerWidth/w,window.innerHeight/h,1);
  x=(window.innerWidth-w*s)/2;y=(window.innerHeight-h*s)/2;put();});});
box.addEventListener('wheel',function(ev){ev.preventDefault();
 var f=ev.deltaY<0?1.25:0.8;x=ev.clientX-(ev.clientX-x)*f;y=ev.clientY-(ev.clientY-y)*f;
 s*=f;put();},{passive:false});
box.addEventListener('mousedown',function(ev){drag=[ev.clientX-x,ev.clientY-y];
 ev.preventDefault();});
window.addEventListener('mousemove',function(ev){if(drag){x=ev.clientX-drag[0];
 y=ev.clientY-drag[1];put();}});
window.addEventListener('mouseup',function(){drag=null;});
box.addEventListener('dblclick',close);
document.addEventListener('keydown',function(ev){if(ev.key==='Escape'){close();}});
})();
"""


def num(x: Any, unit: str = "", key: Sequence[str] | None = None, digits: int = 4,
        scale: float = 1.0) -> str:
    """``x * scale`` in engineering notation; with ``key`` (the JSON path of ``x`` in the
    run's document) wrapped in a span that the browser test reads back (``data-scale``
    says how the shown number relates to the document's, e.g. 100 for a ratio in %)."""
    if isinstance(x, bool) or not (x is None or isinstance(x, int | float)):
        return E(str(x))
    text = E(si(None if x is None else x * scale, unit, digits))
    if key is None or x is None:
        return text
    k = E(json.dumps(list(key)))
    sc = "" if scale == 1.0 else f" data-scale='{scale:g}'"
    return f"<span class='num' data-key='{k}' data-unit='{E(unit)}'{sc}>{text}</span>"


def table(head: Sequence[str], rows: Sequence[Sequence[Any]], cls: str = "") -> str:
    """An HTML table; cells are HTML already (use :func:`num` or escape text)."""
    h = "".join(f"<th>{c}</th>" for c in head)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in rows)
    c = f" class='{cls}'" if cls else ""
    return f"<table{c}><tr>{h}</tr>{body}</table>"


@dataclass(frozen=True)
class Check:
    """A headline figure: this run's value against the reference and the goal.

    ``ok`` is True (goal met), False (missed) or None (no goal: information).
    """

    label: str
    value: str
    reference: str
    goal: str
    ok: bool | None


def mark(ok: bool | None) -> str:
    if ok is None:
        return "<span class='info'>–</span>"
    return "<span class='pass'>✔ pass</span>" if ok else "<span class='fail'>✘ fail</span>"


def summary(title: str, subtitle: str, checks: Sequence[Check], look: Sequence[str],
            key_figure: str, reference_name: str = "paper") -> str:
    """The first screen: verdict, the checks table, what to look at, the key figure."""
    judged = [c for c in checks if c.ok is not None]
    met = sum(1 for c in judged if c.ok)
    verdict = (f"{met} of {len(judged)} goals met" if judged else "no goals to judge")
    cls = "pass" if judged and met == len(judged) else ("fail" if judged else "info")
    rows = [(E(c.label), c.value, c.reference, c.goal, mark(c.ok)) for c in checks]
    items = "".join(f"<li>{t}</li>" for t in look) or "<li>nothing stands out</li>"
    return (f"<section id='summary'><div><h1>{E(title)}</h1><p class='sub'>{subtitle}</p>"
            f"<p class='verdict {cls}'>{E(verdict)}</p>"
            + table(["figure", "this run", E(reference_name), "goal", ""], rows)
            + f"<b>What to look at</b><ul class='look'>{items}</ul></div>"
            f"<div class='key'>{key_figure}</div></section>")


def figure(fig_dir: Path | None, name: str, caption: str = "") -> str:
    """``<figure>`` with the PNG ``fig_dir/name`` embedded (base64); a missing file gives a
    short note instead of a broken image."""
    cap = E(caption or name)
    if fig_dir is None or not (fig_dir / name).is_file():
        return f"<p class='info'>(figure {E(name)} not available)</p>"
    data = base64.b64encode((fig_dir / name).read_bytes()).decode("ascii")
    return (f"<figure><img src='data:image/png;base64,{data}' alt='{cap}' "
            f"data-name='{E(name)}'><figcaption>{cap}</figcaption></figure>")


def html_page(title: str, body: Sequence[str]) -> str:
    """The whole document: head with inline CSS, ``body`` parts, the zoom overlay."""
    return ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width,initial-scale=1'>"
            f"<title>{E(title)}</title><style>{CSS}</style></head><body><main>\n"
            + "\n".join(body)
            + "\n</main><div id='zoom'><span class='hint'>wheel: "
            "zoom, drag: pan, double click or Esc: close</span></div>"
            f"<script>{ZOOM_JS}</script></body></html>\n")
