"""The scenario language: tokenizer, parser, argument types, command table."""
