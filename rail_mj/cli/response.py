"""`rail-mj response`: a layout's frequency response to track irregularities, from its
linearisation (rail_mj.analysis.response), and its rms response to a track spectrum."""

from __future__ import annotations

import json

import click

from rail_mj.cli.options import (
    EXIT_BAD_INPUT,
    Failure,
    check_outputs,
    check_profile_outputs,
    check_speed,
    csv_beside,
    layout_of,
    span_of,
    track_of,
    uses_stdout,
    written,
)
from rail_mj.studies.span import FREQUENCIES

# What is shown when no --outputs is given: the leading wheelset's lateral motion, its guiding force
# and (a spatial vehicle) its left wheel's load, and the car body's floor accelerations; the trailing
# wheelsets see the same rails later and answer alike (`--outputs all` for every one).
DEFAULT_OUTPUTS = ("y1", "sum_y1", "q_left1", "floor_*")
# An input's response this small against the largest of its output (relative) is none: on cones a
# symmetric vehicle about its centred state answers a gauge change only in second order, and level
# moves nothing sideways (on profiles each wheel's forces do answer both, linearly).
NO_RESPONSE = 1e-9
# m/s: below this the creep damping (the creep forces' rate terms over V) makes the linearisation
# stiff beyond any use; a run there is refused too (rail_mj.simulation.timestep).
MIN_SPEED = 1.0


def _names(option: str, text: str | None) -> list[str] | None:
    if text is None:
        return None
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise Failure(f"{option}: give names separated by commas, got {text!r}", EXIT_BAD_INPUT)
    return names


def _band(text: str | None):
    from rail_mj.track import TrackError
    from rail_mj.track.irregularities import DEFAULT_BAND, check_band

    if text is None:
        return DEFAULT_BAND
    try:
        return check_band(text.split(","))
    except TrackError as e:
        raise Failure(f"--wavelengths {text}: {str(e).split(': ', 1)[-1]}", EXIT_BAD_INPUT) from None


def _spectrum(spectrum_name, wavelengths, scale, track):
    """(Spectrum, band, scale, what) from --spectrum/--wavelengths/--scale or --track; None: no spectrum."""
    from rail_mj.track import TrackError
    from rail_mj.track.irregularities import spectrum

    if track is not None:
        if spectrum_name is not None or wavelengths is not None or scale is not None:
            raise Failure(
                "--track gives the spectrum, band and scale: no --spectrum, --wavelengths or --scale with it",
                EXIT_BAD_INPUT,
            )
        the_track = track_of(track)
        irregular = None if the_track is None else the_track.irregularities
        if irregular is None:
            raise Failure(f"--track {track}: no [irregularities]: give a spectrum there, or --spectrum", EXIT_BAD_INPUT)
        if irregular.spectrum is None:
            raise Failure(
                f"--track {track}: its irregularities are measured, not a spectrum: give --spectrum", EXIT_BAD_INPUT
            )
        return spectrum(irregular.spectrum), irregular.wavelengths, irregular.scale, track
    if spectrum_name is None:
        if wavelengths is not None or scale is not None:
            raise Failure("--wavelengths and --scale go with --spectrum (or --track)", EXIT_BAD_INPUT)
        return None
    try:
        spec = spectrum(spectrum_name)
    except TrackError as e:
        raise Failure(f"--spectrum: {str(e).split(': ', 1)[-1]}", EXIT_BAD_INPUT) from None
    scale = 1.0 if scale is None else scale
    if not (scale == scale and 0.0 <= scale < float("inf")):
        raise Failure(f"--scale must be a number >= 0, got {scale}", EXIT_BAD_INPUT)
    return spec, _band(wavelengths), scale, spec.name


@click.command("response")
@click.argument("layout", type=click.Path(dir_okay=False))
@click.option("--speed", type=float, required=True, help="Forward speed, m/s.")
@click.option(
    "--inputs",
    help="Track channels, separated by commas: alignment, level, cross_level, gauge  [default: all the "
    "vehicle takes; a planar vehicle the lateral ones, alignment and gauge]",
)
@click.option(
    "--outputs",
    help="Responses, names or patterns separated by commas, as a run's CSV names them (y1, psi2, sum_y*, "
    "q_left1, y_over_q_*, y_carbody, roll_carbody) and floor_lateral_<point>, floor_vertical_<point> "
    "(bogie1, bogie2, centre; not for trains, whose runs have none either); 'all' for every one  "
    "[default: y1,sum_y1,q_left1,floor_*]",
)
@click.option(
    "--frequencies",
    default="0.1:30:400:log",
    show_default=True,
    help="A:B:N[:log], Hz: where the transfer functions are given.",
)
@click.option(
    "--spectrum",
    "spectrum_name",
    help="A track spectrum (erri-low, erri-high, fra-1 ... fra-6): the rms of each output under it.",
)
@click.option("--wavelengths", help="A,B: with --spectrum, the band of wavelengths kept, m  [default: 3,150]")
@click.option("--scale", type=float, help="With --spectrum: a multiplier on its amplitudes  [default: 1]")
@click.option(
    "--track",
    type=click.Path(dir_okay=False),
    help="A track file whose [irregularities] give the spectrum, band and scale (instead of --spectrum).",
)
@click.option(
    "--amplitude",
    type=float,
    default=None,
    help="For a layout with [profiles]: linearise the contact at this lateral amplitude, mm  [default: 3]",
)
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="The transfer functions, PNG.")
@click.option(
    "--csv", "csv_path", type=click.Path(dir_okay=False), help="The data as CSV [default: the plot's name with .csv]."
)
@click.option("--json", "as_json", is_flag=True, help="Print the peaks (and rms) as JSON.")
def response_cmd(
    layout,
    speed,
    inputs,
    outputs,
    frequencies,
    spectrum_name,
    wavelengths,
    scale,
    track,
    amplitude,
    out,
    csv_path,
    as_json,
):
    """Transfer functions from each track irregularity channel of LAYOUT at SPEED to its wheelsets'
    motion, wheel forces and car-body floor accelerations, from its linearisation about the centred
    state; with a spectrum the rms of each, integral |H|^2 S over the band (channels independent).
    Gains are per metre of irregularity; phases are the output's lead over the irregularity under
    the vehicle's centre."""
    lay = layout_of(layout)
    check_speed("--speed", speed)
    if speed < MIN_SPEED:
        raise Failure(f"--speed must be at least {MIN_SPEED:g} m/s for a response, got {speed:g}", EXIT_BAD_INPUT)
    freqs = span_of("--frequencies", frequencies, FREQUENCIES).values()
    channels = _names("--inputs", inputs)
    if channels is not None:
        channels = list(dict.fromkeys(channels))  # each once, in the order given
    patterns = _names("--outputs", outputs)
    stochastic = _spectrum(spectrum_name, wavelengths, scale, track)
    csv_path = csv_beside(out, csv_path, "the plot and the data")
    if as_json and uses_stdout(out, csv_path):
        raise Failure("--json prints to standard output: write -o and --csv to files", EXIT_BAD_INPUT)
    check_outputs(layout, [("-o", out), ("--csv", csv_path)])
    check_profile_outputs(lay, [("-o", out), ("--csv", csv_path)])
    if track is not None:
        check_outputs(track, [("-o", out), ("--csv", csv_path)], source="the track file")
    from rail_mj.analysis.response import Response
    from rail_mj.output.plots import response_csv, response_png
    from rail_mj.track.irregularities import CHANNELS

    for c in channels or ():
        if c not in CHANNELS:
            raise Failure(f"--inputs: {c!r} is no channel: one of {', '.join(CHANNELS)}", EXIT_BAD_INPUT)
    try:
        response = Response(lay, speed, amplitude)
    except ValueError as e:  # the amplitude is not for this contact, or the vehicle takes no track
        raise Failure(
            f"--amplitude: {e}" if amplitude is not None and "amplitude" in str(e) else str(e), EXIT_BAD_INPUT
        ) from None
    try:
        response.check_stable()
    except ValueError as e:  # above the critical speed: no steady response
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    channels = channels or list(response.inputs)
    for c in channels:
        if c not in response.inputs:
            raise Failure(
                f"--inputs: {lay.name} takes {', '.join(response.inputs)}, not {c} (a planar vehicle has no "
                f"vertical motion: give it [spatial] for the vertical channels)",
                EXIT_BAD_INPUT,
            )
    if patterns == ["all"]:
        chosen = list(response.outputs)
    else:
        try:
            chosen = response.select(patterns) if patterns else response.select(DEFAULT_OUTPUTS, strict=False)
        except ValueError as e:
            raise Failure(f"--outputs: {e}", EXIT_BAD_INPUT) from None
    picked = [response.outputs.index(n) for n in chosen]
    selected = [response.output(n) for n in chosen]
    gains = {c: response.transfer(c, freqs)[:, picked] for c in channels}
    rms = variance = None
    if stochastic is not None:
        spec, band, factor, _ = stochastic
        variance = {c: v[picked] for c, v in response.variance(spec, band, factor, channels).items()}
        rms = {o.name: float(sum(v[k] for v in variance.values())) ** 0.5 for k, o in enumerate(selected)}
    title = f"{lay.name} at {speed:g} m/s: response to track irregularities"
    if response.amplitude is not None:
        title += f"\n(contact linearised at {response.amplitude:g} mm)"
    with written([csv_path, out]) as (csv_tmp, png_tmp):
        csv_tmp.write_bytes(response_csv(freqs, speed, gains, selected))
        shares = None
        if variance is not None:
            shares = {(o.name, c): float(v[k]) ** 0.5 for c, v in variance.items() for k, o in enumerate(selected)}
        png_tmp.write_bytes(response_png(freqs, speed, gains, selected, title, shares))
    err = uses_stdout(out, csv_path) or as_json
    peaks: dict[str, dict[str, dict | None]] = {}
    for k, o in enumerate(selected):
        top = max(float(abs(g[:, k]).max()) for g in gains.values())
        peaks[o.name] = {}
        for c, g in gains.items():
            j = int(abs(g[:, k]).argmax())
            gain = float(abs(g[j, k]))
            peaks[o.name][c] = None if gain <= NO_RESPONSE * top else {"gain": gain, "frequency_hz": freqs[j]}
    if as_json:
        doc = {
            "layout": lay.name,
            "speed_m_per_s": speed,
            "amplitude_mm": response.amplitude,
            "inputs": channels,
            "frequencies_hz": [freqs[0], freqs[-1], len(freqs)],
            "spectrum": None,
            "outputs": {},
        }
        if stochastic is not None:
            spec, band, factor, what = stochastic
            doc["spectrum"] = {"name": spec.name, "wavelengths_m": list(band), "scale": factor, "from": what}
        for k, o in enumerate(selected):
            entry: dict = {"unit": o.unit, "gain_unit": o.gain_unit, "peak": peaks[o.name]}
            if variance is not None and rms is not None:
                entry["rms"] = {c: float(v[k]) ** 0.5 for c, v in variance.items()} | {"total": rms[o.name]}
            doc["outputs"][o.name] = entry
        click.echo(json.dumps(doc, indent=2))
    else:
        _say(lay.name, speed, response, selected, channels, peaks, variance, rms, stochastic, err)
    click.echo(f"plot: {out}\ndata: {csv_path}", err=err)


def _say(name, speed, response, selected, channels, peaks, variance, rms, stochastic, err) -> None:
    echo = lambda text: click.echo(text, err=err)  # noqa: E731
    how = f" ({response.amplitude:g} mm linearisation)" if response.amplitude is not None else ""
    echo(f"{name} at {speed:g} m/s{how}: peak gain per input (per m of irregularity) at its frequency")
    width = max(len(o.name) for o in selected)
    echo(f"{'output':<{width}}  {'unit':<14}" + "".join(f"  {c:>22}" for c in channels))
    for o in selected:
        cells = []
        for c in channels:
            p = peaks[o.name][c]
            cells.append(f"  {'-':>22}" if p is None else f"  {p['gain']:>11.4g} @ {p['frequency_hz']:>5.2f} Hz")
        echo(f"{o.name:<{width}}  {o.gain_unit:<14}" + "".join(cells))
    if stochastic is None or variance is None or rms is None:
        return
    spec, band, factor, what = stochastic
    echo(f"rms under {spec.name} ({band[0]:g}-{band[1]:g} m, x{factor:g}, from {what}), channels independent:")
    shown = list(variance)
    echo(f"{'output':<{width}}  {'unit':<8}" + "".join(f"  {c:>12}" for c in shown) + f"  {'total':>12}")
    for k, o in enumerate(selected):
        row = "".join(f"  {float(variance[c][k]) ** 0.5:>12.4g}" for c in shown)
        echo(f"{o.name:<{width}}  {o.unit or '-':<8}{row}  {rms[o.name]:>12.4g}")
    missing = [c for c in channels if c not in variance]
    if missing:
        echo(f"({spec.name} gives no {', '.join(missing)}: none taken)")
