"""The portable decoder: gimbalscope's deframing, dissection and pairing as
plain Python source that other tools' embedded interpreters run without
gimbalscope (libsigrokdecode's, for the sigrok decoder; Saleae Logic 2's, for
its High Level Analyzer). ``table`` writes the command and problem tables as
data, ``frame_decoder`` the code over them; the sigrok and Saleae generators
put the one text into their files (docs/instruments.md)."""
