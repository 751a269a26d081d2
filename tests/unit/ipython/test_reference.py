"""The magics reference is read from the magics' own parsers: every registered magic, every option."""

from __future__ import annotations

from IPython.core.interactiveshell import InteractiveShell

from ipyros.ipython.extension import Extension
from ipyros.ipython.reference import entries, magics_classes


def test_the_reference_holds_every_magic_the_extension_registers():
    registered = Extension(InteractiveShell.instance()).magics
    assert {type(m) for m in registered} == set(magics_classes())
    names = {name for m in registered for kind in ("line", "cell") for name in m.magics[kind]}
    assert {e.name for e in entries()} == names


def test_an_entry_has_the_parsers_usage_options_and_help():
    pub = next(e for e in entries() if e.name == "pub")
    assert pub.title == "%pub / %%pub"
    assert pub.usage.startswith("%pub [-t TYPE] [-r RATE]")
    options = {o.spelling: o for o in pub.options}
    assert options["-r RATE, --rate RATE"].help == "publish again at this rate (Hz) until Ctrl-C"
    assert options["topic"].positional and not options["--latch"].positional
    assert "(or the cell of %%pub)" in options["data"].help  # argparse's %% escape undone once
    kinds = [kind for kind, _ in pub.blocks()]
    assert kinds[0] == "text" and "code" in kinds  # the docstring's examples stay code


def test_the_estop_entry_says_what_it_does_not_promise():
    estop = next(e for e in entries() if e.name == "estop")
    assert "Not certified functional safety" in " ".join(text for _, text in estop.blocks())
    assert [o.spelling for o in estop.options] == ["node", "--release"]
