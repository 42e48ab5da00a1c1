"""``taptune record``: record taps from the microphone into a WAV file (headless).

Waits for taps, keeps ``--taps`` of them (each with its pre-trigger sound) and writes the
WAV after every tap, so an interruption or a lost device keeps what was recorded. With
``--assembly`` the assembly file is copied beside the WAV (same stem, ``.toml``), the
sidecar that ``taptune batch`` and the GUI read.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path


def add_parser(sub, name: str, help_text: str) -> None:
    p = sub.add_parser(name, help=help_text, description=help_text + ".")
    p.add_argument("--out", metavar="WAV", help="the WAV file to write (required unless --list-devices)")
    p.add_argument("--seconds", type=float, default=60.0, metavar="S",
                   help="stop waiting for taps after S seconds (default 60)")
    p.add_argument("--device", default=None, metavar="ID", help="input device number or part of its name (default: the system default)")
    p.add_argument("--taps", type=int, default=5, metavar="N", help="taps to record (default 5)")
    p.add_argument("--sample-rate", type=int, default=48000, metavar="HZ", help="sample rate (default 48000)")
    p.add_argument("--assembly", metavar="FILE", help="assembly file to save beside the WAV")
    p.add_argument("--list-devices", action="store_true", help="list the input devices and exit")


def run(args) -> int:
    from taptune.errors import DeviceError, InputError
    from taptune.io import recording

    try:
        if args.list_devices:
            devices = recording.input_devices()
            for device in devices:
                print(device.label())
            if not devices:
                print("no audio input device found")
            return 0
        if not args.out:
            raise InputError("--out WAV is required (where to save the taps)")
        from taptune.cli.common import command_inputs, output_path

        output_path(args.out, "recording", create=False, inputs=command_inputs(args))
        recording.record_format(args.out)
        if args.taps <= 0 or not 0 < args.seconds < float("inf"):
            raise InputError(f"--taps and --seconds must be > 0 (and finite), got {args.taps} and {args.seconds:g}")
        from taptune.io.audio import MIN_SAMPLE_RATE

        # Below 8 kHz the bending modes are not in the recording; above 384 kHz no sound card.
        if not MIN_SAMPLE_RATE <= args.sample_rate <= 384000:
            raise InputError(f"--sample-rate must lie in {MIN_SAMPLE_RATE}…384000 Hz (48000 recommended), "
                             f"got {args.sample_rate}")
        assembly_text = None
        if args.assembly:
            from taptune.io.assembly import assembly_from_toml
            from taptune.io.files import read_text

            # Read once, validate before waiting for taps, save the same text beside the WAV.
            assembly_text = read_text(args.assembly, "an assembly file", "TOML")
            for warning in assembly_from_toml(assembly_text, args.assembly).warnings:
                print(f"taptune record: warning: {warning}", file=sys.stderr)
        settings = recording.TriggerSettings(sample_rate=args.sample_rate, n_taps=args.taps)
        device = recording.find_input_device(args.device)
    except DeviceError as err:
        # No audio library or no device is a problem with the user's set-up, like a bad
        # file: one line and exit 2 (docs/cli.md).
        print(f"taptune record: {err}", file=sys.stderr)
        return 2
    try:
        return _record(recording, settings, device, Path(args.out), assembly_text, args.seconds)
    except DeviceError as err:
        # The device failed while recording (unplugged): the message says what was kept.
        print(f"taptune record: {err}", file=sys.stderr)
        return 1


def _record(recording, settings, device, out: Path, assembly_text, seconds: float) -> int:
    say = lambda text: print(text, file=sys.stderr, flush=True)  # noqa: E731 - progress goes to stderr
    say(f"recording from {device.label()}; tap the tool tip {settings.n_taps} times (Ctrl-C stops)")
    recorder = recording.Recorder(out, settings, device=device.index, assembly_toml=assembly_text)
    deadline = time.monotonic() + seconds
    ready_said = False
    with recorder:
        while not recorder.done and time.monotonic() < deadline:
            for event in recorder.poll(timeout=0.1):
                if event.kind == "tap":
                    say(f"tap {event.index}/{settings.n_taps} ({event.level_db:.0f} dBFS)")
                elif event.kind == "rejected":
                    say(f"tap not kept: {event.message}")
            if not ready_said and recorder.trigger.ready:
                say("listening…")
                ready_said = True
    if recorder.saved_taps == 0:
        say(f"taptune record: no tap heard in {seconds:g} s (is the microphone on and close to the tool?)")
        return 1
    if not recorder.done:
        say(f"stopped after {seconds:g} s with {recorder.saved_taps} of {settings.n_taps} taps")
    print(f"saved {recorder.saved_taps} taps to {out}" + (f" and the assembly to {recorder.sidecar_path}" if assembly_text else ""))
    return 0
