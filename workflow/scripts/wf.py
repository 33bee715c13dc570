#!/usr/bin/env python3
"""Helpers of workflow/Snakefile (standard library only).

  wf.py stage   --status S.json [--dir D] --log L [--after A.json ...] --cmd 'shadowsg ...' [--cmd ...]
  wf.py item    --name N --kind scene|capture --dir D --out item.json STATUS.json ...
  wf.py summary --shadowsg BIN --setting sg:fast --threads T --out DIR --log L ITEM.json ...
  wf.py check   ITEM.json --ok OK

A stage's status file (format "shadowsg-workflow-stage/1") says whether it ran
(`ok`), failed on its input (`error`: shadowsg's one-line message) or was
skipped because an earlier stage of the item failed. Exit status 1 from
shadowsg is bad input: recorded, and the job succeeds so that the summary can
list the item. Any other failure (a crash, a signal, a missing binary) fails
the job itself.
"""

import argparse
import csv
import html
import io
import json
import os
import shlex
import shutil
import subprocess
import sys
import time

STAGE_FORMAT = "shadowsg-workflow-stage/1"
ITEM_FORMAT = "shadowsg-workflow-item/1"


def write_atomically(path, text):
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def write_json(path, value):
    write_atomically(path, json.dumps(value, indent=2, sort_keys=True) + "\n")


def read_json(path):
    with open(path) as f:
        return json.load(f)


def stage_name(status_path):
    return os.path.splitext(os.path.basename(status_path))[0]


def error_line(output):
    lines = [l.strip() for l in output.splitlines() if l.strip()]
    errors = [l for l in lines if l.startswith("error:")]
    return errors[-1] if errors else (lines[-1] if lines else "failed without a message")


# ---------------------------------------------------------------- stage

def cmd_stage(a):
    stage = stage_name(a.status)
    item = os.path.basename(os.path.dirname(os.path.abspath(a.status)))
    os.makedirs(os.path.dirname(os.path.abspath(a.log)), exist_ok=True)
    if a.dir:
        os.makedirs(a.dir, exist_ok=True)
    status = {"format": STAGE_FORMAT, "item": item, "stage": stage, "host": os.uname().nodename,
              "slurm_job_id": os.environ.get("SLURM_JOB_ID"), "log": a.log, "dir": a.dir, "commands": a.cmd}
    for after in a.after:
        prev = read_json(after)
        if not prev.get("ok"):
            status.update(ok=False, skipped=True, error=f"not run: {prev.get('stage')} failed",
                          failed_stage=prev.get("failed_stage", prev.get("stage")))
            write_atomically(a.log, f"{stage}: not run, {prev.get('stage')} failed: {prev.get('error')}\n")
            write_json(a.status, status)
            return 0
    start = time.time()
    with open(a.log, "w") as log:
        for c in a.cmd:
            argv = shlex.split(c)
            log.write("$ " + c + "\n")
            log.flush()
            t0 = time.time()
            try:
                p = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
                rc, out = p.returncode, p.stdout
            except OSError as e:  # the binary is missing: the workflow's problem, not the item's
                print(f"error: {argv[0]}: {e.strerror}", file=sys.stderr)
                return 2
            log.write(out)
            log.write(f"[exit status {rc}, {time.time() - t0:.2f} s]\n")
            log.flush()
            if rc == 1:  # shadowsg's bad-input exit: record it, let the other items go on
                msg = error_line(out)
                status.update(ok=False, skipped=False, error=msg, failed_stage=stage, exit_status=rc,
                              seconds=time.time() - start)
                write_json(a.status, status)
                print(f"shadowsg {stage} failed on item {item}: {msg} (log: {a.log})", file=sys.stderr)
                return 0
            if rc != 0:
                sys.stderr.write(out[-4000:])
                print(f"error: {argv[0]} {argv[1] if len(argv) > 1 else ''}: exit status {rc} on item {item} "
                      f"(log: {a.log}); the job fails and is retried on the next run", file=sys.stderr)
                return rc if 0 < rc < 256 else 1
    status.update(ok=True, seconds=time.time() - start)
    write_json(a.status, status)
    return 0


# ---------------------------------------------------------------- item

def cmd_item(a):
    stages = {}
    for s in a.statuses:
        st = read_json(s)
        stages[st["stage"]] = st
    failed = [st for st in stages.values() if not st.get("ok") and not st.get("skipped")]
    item = {"format": ITEM_FORMAT, "item": a.name, "kind": a.kind, "dir": a.dir, "ok": not failed and all(
        st.get("ok") for st in stages.values()), "stages": stages, "metrics": {}}
    if failed:
        item.update(failed_stage=failed[0]["stage"], error=failed[0]["error"], log=failed[0]["log"])
    elif not item["ok"]:
        skipped = next(st for st in stages.values() if not st.get("ok"))
        item.update(failed_stage=skipped.get("failed_stage"), error=skipped.get("error"), log=skipped.get("log"))
    out_dir = os.path.dirname(a.out)
    if a.kind == "capture":
        run = os.path.join(out_dir, "run")
        item["scene_dir"] = os.path.join(run, "scene")
        places = {"solve": os.path.join(run, "solve"), "composite": os.path.join(run, "composite")}
    else:
        item["scene_dir"] = a.dir
        places = {s: os.path.join(out_dir, s) for s in ("solve", "composite", "eval")}
    for s, d in places.items():
        m = os.path.join(d, "metrics.json")
        if item["ok"] and os.path.isfile(m):
            item["metrics"][s] = read_json(m)
            item.setdefault("run_dirs", {})[s] = d
    write_json(a.out, item)
    return 0


# ---------------------------------------------------------------- check

def cmd_check(a):
    item = read_json(a.item)
    if item["ok"]:
        with open(a.ok, "w") as f:
            f.write("ok\n")
        return 0
    print(f"error: item {item['item']} ({item['dir']}) failed at {item.get('failed_stage')}: {item.get('error')} "
          f"(log: {item.get('log')})", file=sys.stderr)
    # The failed and skipped stages are redone on the next run, and with them the
    # item and the summary (Snakemake only rebuilds a missing file that something
    # it must make needs: the item record goes too).
    for st in item["stages"].values():
        if not st.get("ok"):
            status = os.path.join(os.path.dirname(a.item), st["stage"] + ".json")
            if os.path.exists(status):
                os.remove(status)
    os.remove(a.item)
    return 1


# ---------------------------------------------------------------- summary

def bench_run_name(setting):
    method, _, arg = setting.partition(":")
    if method in ("ss03", "ss03+", "sh21"):
        return f"{method}-h{arg}"
    return f"{method}-{arg}"


def benchable(item, setting):
    """The item's solve is the bench setting's (a capture's solve comes from its capture.json)."""
    m = item["metrics"].get("solve")
    if not item["ok"] or not m:
        return False
    method, _, arg = setting.partition(":")
    if m.get("method") != method:
        return False
    if method == "sg":
        return (m.get("report") or {}).get("budget") == arg and not (m.get("report") or {}).get("forced_lobes")
    return True


def fmt(v, digits=3):
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return "" if v is None else str(v)


def replace_link(link, target):
    if os.path.islink(link) or os.path.isfile(link):
        os.remove(link)
    elif os.path.isdir(link):
        shutil.rmtree(link)
    os.symlink(target, link)


def cmd_summary(a):
    out = a.out
    os.makedirs(out, exist_ok=True)
    items = [read_json(p) for p in a.items]
    run_name = bench_run_name(a.setting)
    method, _, setting_arg = a.setting.partition(":")

    # Scenes and reused runs for `shadowsg bench`: scenes/<item> -> the scene folder,
    # runs/<item>/<setting> -> the item's solve folder (bench reuses a run whose
    # metrics.json exists).
    scenes_dir = os.path.join(out, "scenes")
    shutil.rmtree(scenes_dir, ignore_errors=True)
    os.makedirs(scenes_dir)
    bench_items = [it for it in items if benchable(it, a.setting)]
    for it in items:
        link = os.path.join(out, "runs", it["item"], run_name)
        if it in bench_items:
            os.makedirs(os.path.dirname(link), exist_ok=True)
            replace_link(link, os.path.relpath(os.path.abspath(it["run_dirs"]["solve"]), os.path.dirname(os.path.abspath(link))))
            os.symlink(os.path.abspath(it["scene_dir"]), os.path.join(scenes_dir, it["item"]))
        elif os.path.islink(link):
            os.remove(link)

    bench_ok = False
    with open(a.log, "w") as log:
        if bench_items:
            argv = [a.shadowsg, "bench"] + [os.path.join(scenes_dir, it["item"]) for it in bench_items] + [
                "--methods", a.setting, "--out", out, "--threads", str(a.threads), "--quiet"]
            log.write("$ " + " ".join(shlex.quote(x) for x in argv) + "\n")
            log.flush()
            p = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            log.write(p.stdout + f"[exit status {p.returncode}]\n")
            if p.returncode != 0:
                sys.stderr.write(p.stdout[-4000:])
                print(f"error: shadowsg bench failed (exit status {p.returncode}; log: {a.log})", file=sys.stderr)
                return 1
            bench_ok = True
        else:
            log.write("no item finished: no bench\n")

    # results.csv: bench's rows, then one row per failed item (its error) and per
    # finished item whose solve is not the bench setting (a capture's own settings).
    results = os.path.join(out, "results.csv")
    if bench_ok:
        with open(results, newline="") as f:
            rows = list(csv.reader(f))
        header, body = rows[0], rows[1:]
    else:
        header, body = ["scene", "method", "setting", "run", "psnr", "ssim", "run_dir", "reused", "error"], []
    col = {h: i for i, h in enumerate(header)}
    for it in items:
        if it in bench_items:
            continue
        row = [""] * len(header)
        m = it["metrics"].get("solve", {})
        row[col["scene"]] = it["item"]
        row[col["method"]] = m.get("method", method)
        row[col["setting"]] = (m.get("report") or {}).get("budget", setting_arg) if m else setting_arg
        for k, v in m.items():
            if k in col and k not in ("scene", "method", "setting") and not isinstance(v, (dict, list)):
                row[col[k]] = fmt(v, 17) if isinstance(v, float) else ("" if v is None else str(v))
        if "run_dir" in col and it.get("run_dirs", {}).get("solve"):
            row[col["run_dir"]] = os.path.relpath(it["run_dirs"]["solve"], out)
        row[col["error"]] = "" if it["ok"] else f"{it.get('failed_stage')}: {it.get('error')}"
        body.append(row)
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows([header] + body)
    write_atomically(results, buf.getvalue())

    # items.csv: one row per item; failed.csv: the failed items.
    cols = ["item", "kind", "status", "failed_stage", "error", "psnr", "ssim", "env_angular_error_deg",
            "insert_psnr", "insert_ssim", "eval_psnr", "n_lobes", "solve_seconds", "stage_seconds", "hosts",
            "slurm_job_ids", "dir", "log"]
    rows = []
    for it in items:
        s = it["metrics"].get("solve", {})
        c = it["metrics"].get("composite", {})
        e = it["metrics"].get("eval", {})
        stages = it["stages"]
        rows.append({
            "item": it["item"], "kind": it["kind"], "status": "ok" if it["ok"] else "failed",
            "failed_stage": it.get("failed_stage") or "", "error": it.get("error") or "",
            "psnr": s.get("psnr"), "ssim": s.get("ssim"), "env_angular_error_deg": s.get("env_angular_error_deg"),
            "insert_psnr": c.get("insert_psnr", s.get("insert_psnr")), "insert_ssim": c.get("insert_ssim", s.get("insert_ssim")),
            "eval_psnr": e.get("psnr"), "n_lobes": s.get("n_lobes"), "solve_seconds": s.get("solve_seconds"),
            "stage_seconds": " ".join(f"{k}={v['seconds']:.2f}" for k, v in stages.items() if "seconds" in v),
            "hosts": " ".join(sorted({v["host"] for v in stages.values() if v.get("host")})),
            "slurm_job_ids": " ".join(v["slurm_job_id"] for v in stages.values() if v.get("slurm_job_id")),
            "dir": it["dir"], "log": it.get("log") or ""})
    for name, keep in (("items.csv", lambda r: True), ("failed.csv", lambda r: r["status"] == "failed")):
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(cols if name == "items.csv" else ["item", "kind", "failed_stage", "error", "dir", "log"])
        for r in rows:
            if keep(r):
                w.writerow([fmt(r[k]) for k in (cols if name == "items.csv" else
                                                 ["item", "kind", "failed_stage", "error", "dir", "log"])])
        write_atomically(os.path.join(out, name), buf.getvalue())

    # index.html: bench's report with a section on the batch (or that section alone).
    n_failed = sum(not it["ok"] for it in items)
    sec = io.StringIO()
    sec.write(f'<section id="batch"><h2>Batch: {len(items)} items, {len(items) - n_failed} finished, '
              f'{n_failed} failed</h2>\n')
    sec.write("<p>Per item (items.csv). Solve scores against the photo; insertion scores from "
              "<code>composite</code>; eval = <code>shadowsg eval</code> of the estimate.</p>\n<table>\n<tr>")
    shown = ["item", "kind", "status", "psnr", "ssim", "insert_psnr", "eval_psnr", "n_lobes", "stage_seconds", "hosts"]
    sec.write("".join(f"<th>{h}</th>" for h in shown) + "</tr>\n")
    for r in rows:
        sec.write("<tr>" + "".join(f"<td>{html.escape(fmt(r[k]))}</td>" for k in shown) + "</tr>\n")
    sec.write("</table>\n")
    sec.write('<h2 id="failed">Failed items</h2>\n')
    if n_failed:
        sec.write("<table>\n<tr><th>item</th><th>folder</th><th>stage</th><th>error</th><th>log</th></tr>\n")
        for r in rows:
            if r["status"] == "failed":
                sec.write(f"<tr><td>{html.escape(r['item'])}</td><td>{html.escape(r['dir'])}</td>"
                          f"<td>{html.escape(r['failed_stage'])}</td><td><code>{html.escape(r['error'])}</code></td>"
                          f"<td>{html.escape(r['log'])}</td></tr>\n")
        sec.write("</table>\n")
    else:
        sec.write("<p>None.</p>\n")
    sec.write("</section>\n")
    index = os.path.join(out, "index.html")
    if bench_ok:
        with open(index) as f:
            page = f.read()
        cut = page.rfind("</body>")
        page = (page[:cut] + sec.getvalue() + page[cut:]) if cut >= 0 else page + sec.getvalue()
    else:
        page = ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>shadowsg batch</title></head><body>\n"
                "<h1>shadowsg batch</h1>\n<p>No item finished: no benchmark tables or charts.</p>\n"
                + sec.getvalue() + "</body></html>\n")
    write_atomically(index, page)
    print(f"summary: {len(items)} items, {n_failed} failed; {index}", file=sys.stderr)
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    p = sub.add_parser("stage")
    p.add_argument("--status", required=True)
    p.add_argument("--dir")
    p.add_argument("--log", required=True)
    p.add_argument("--after", action="append", default=[])
    p.add_argument("--cmd", action="append", required=True)
    p = sub.add_parser("item")
    p.add_argument("--name", required=True)
    p.add_argument("--kind", required=True, choices=["scene", "capture"])
    p.add_argument("--dir", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("statuses", nargs="+")
    p = sub.add_parser("check")
    p.add_argument("item")
    p.add_argument("--ok", required=True)
    p = sub.add_parser("summary")
    p.add_argument("--shadowsg", required=True)
    p.add_argument("--setting", required=True)
    p.add_argument("--threads", type=int, required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--log", required=True)
    p.add_argument("items", nargs="+")
    a = ap.parse_args()
    return {"stage": cmd_stage, "item": cmd_item, "check": cmd_check, "summary": cmd_summary}[a.command](a)


if __name__ == "__main__":
    sys.exit(main())
