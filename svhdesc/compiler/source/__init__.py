"""svhdesc/compiler/source"""
