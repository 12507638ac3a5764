"""mkdocs hook: the committed results, served from where they are.

Every results folder's figures, its `report/` and its `budgets/` (their .md, their figures)
appear in the site under `records/<suite>/...`, read from `results/<suite>/...` at build time,
so the results pages show the same files the records produced and no number or figure is
copied into docs/.
"""

from __future__ import annotations

from pathlib import Path

from mkdocs.structure.files import File, Files

RESULTS = Path(__file__).resolve().parents[2] / "results"
SERVED = ("*.png", "report/*.png", "report/*.md", "budgets/*.png", "budgets/*.md")


def on_files(files: Files, config) -> Files:
    for folder in sorted(p for p in RESULTS.iterdir() if (p / "trials").is_dir()):
        for pattern in SERVED:
            for path in sorted(folder.glob(pattern)):
                uri = f"records/{folder.name}/{path.relative_to(folder).as_posix()}"
                files.append(File.generated(config, uri, abs_src_path=str(path)))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    """A page links a committed figure by its path in the repository (`../results/<suite>/...`
    from docs/index.md), which renders on the repository's own page as plain markdown; in the
    site the same file is served under records/, so the link is pointed there."""
    depth = page.file.src_uri.count("/")
    return markdown.replace("../" * (depth + 1) + "results/", "../" * depth + "records/")
