"""Gnuplot plots of the reproduction page (bench/reproduce.py): bars with the spread over
runs, clustered bars and lines, each written as NAME.dat + NAME.gp and drawn to NAME.svg."""
import os
import shutil
import subprocess


def spread(values):
    """(median, min, max) of the values that are not None, or None."""
    v = sorted(x for x in values if x is not None)
    if not v:
        return None
    n = len(v)
    return ((v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])), v[0], v[-1])


def lat_mean(p):
    m = p["latency_ms"]["mean"]
    return m if m > 0 else None


def gnuplot(out, name, script, data):
    """Writes plots/NAME.dat and NAME.gp and draws NAME.svg; returns the svg's path relative
    to OUT, or None without gnuplot."""
    d = os.path.join(out, "plots")
    os.makedirs(d, exist_ok=True)
    dat = os.path.join(d, name + ".dat")
    with open(dat, "w") as f:
        f.write(data)
    gp = os.path.join(d, name + ".gp")
    with open(gp, "w") as f:
        f.write(f"set terminal svg size 960,340 dynamic background rgb 'white'\n"
                f"set termoption noenhanced\nset output '{name}.svg'\n" + script)
    if not shutil.which("gnuplot"):
        return None
    r = subprocess.run(["gnuplot", name + ".gp"], cwd=d, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"gnuplot {gp}: {r.stderr.strip()}")
    return os.path.join("plots", name + ".svg")


def bars_with_spread(out, name, title, per):
    """Three panels (miss %, mean ms, QoE): a bar per policy at the median, the range over
    runs as an error bar."""
    rows = ["# policy miss_med miss_min miss_max lat_med lat_min lat_max qoe_med qoe_min qoe_max"]
    for pol, ps in per.items():
        m = spread([100 * p["miss_rate"] for p in ps]) or (0, 0, 0)
        lat = spread([lat_mean(p) for p in ps]) or (0, 0, 0)
        q = spread([p["qoe"] for p in ps]) or (0, 0, 0)
        rows.append(f"{pol} " + " ".join(f"{x:.4f}" for x in (*m, *lat, *q)))
    script = (
        "set style data histograms\nset style histogram errorbars gap 2 lw 1\n"
        "set style fill solid 0.6 border -1\nset grid ytics\nset key off\nset xtics rotate by -30\n"
        f"set multiplot layout 1,3 title '{title} (median, bars: min–max over runs)'\n"
        "set title 'miss rate (%)'\nset yrange [0:*]\nplot 'NAME.dat' using 2:3:4:xtic(1)\n"
        "set title 'mean latency (ms)'\nplot 'NAME.dat' using 5:6:7:xtic(1)\n"
        "set title 'QoE'\nset yrange [0:1.05]\nplot 'NAME.dat' using 8:9:10:xtic(1)\n"
        "unset multiplot\n").replace("NAME", name)
    return gnuplot(out, name, script, "\n".join(rows) + "\n")


def grouped_bars(out, name, title, ylabel, columns, rows):
    """Clustered bars: rows [(label, [value per column])]."""
    data = "label " + " ".join(columns) + "\n" + "".join(
        f"{lab} " + " ".join(f"{(v if v is not None else 0):.4f}" for v in vals) + "\n"
        for lab, vals in rows)
    script = (
        "set style data histograms\nset style histogram clustered gap 1\n"
        "set style fill solid 0.7 border -1\nset grid ytics\nset key outside right\n"
        f"set title '{title}'\nset ylabel '{ylabel}'\nset yrange [0:*]\n"
        f"plot for [i=2:{len(columns) + 1}] '{name}.dat' using i:xtic(1) title columnheader(i)\n")
    return gnuplot(out, name, script, data)


def lines(out, name, title, xlabel, ylabel, xs, series, logx=False):
    """One line per series over xs: series [(label, [y per x])]."""
    data = "x " + " ".join(lab for lab, _ in series) + "\n" + "".join(
        f"{x} " + " ".join("NaN" if ys[i] is None else f"{ys[i]:.4f}" for _, ys in series) + "\n"
        for i, x in enumerate(xs))
    script = (
        ("set logscale x\n" if logx else "") +
        f"set grid\nset key outside right\nset title '{title}'\nset xlabel '{xlabel}'\n"
        f"set ylabel '{ylabel}'\n"
        f"plot for [i=2:{len(series) + 1}] '{name}.dat' using 1:i with linespoints title columnheader(i)\n")
    return gnuplot(out, name, script, data)
