"""One PNG of several images with their titles (the sandstone gallery's sheets):

    python contact_sheet.py [--columns N] [--title TEXT] OUT.png IMAGE TITLE [IMAGE TITLE ...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib.image

from unerode_cli.viz.contact_sheet import save_contact_sheet


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", type=Path, help="the sheet to write (PNG)")
    parser.add_argument("pairs", nargs="+", metavar="IMAGE TITLE", help="each image and its title")
    parser.add_argument("--columns", type=int, default=None,
                        help="panels per row (default: a square-ish grid)")
    parser.add_argument("--title", default="", help="title of the sheet")
    args = parser.parse_args(argv)
    if len(args.pairs) % 2:
        parser.error("give each image followed by its title")
    paths = [Path(p) for p in args.pairs[0::2]]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        parser.error(f"no such image: {', '.join(missing)}")
    images = [matplotlib.image.imread(p) for p in paths]
    save_contact_sheet(args.out, images, args.pairs[1::2], columns=args.columns, title=args.title)
    print(f"wrote {args.out} ({len(images)} images)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
