"""strala's compiler: scene text to the evaluated scene (lang.ir), and the tools that read
scene text (check, fmt, translate, the language server). No numpy, no renderer."""
